// Quaternion log/exp/slerp written once for two scalar types: double, and a
// forward-mode dual number whose derivative part carries d/dt through every
// operation. Evaluating a rotation curve with Dual gives its time derivative
// exact to rounding, which is how the angular velocities are computed.
//
// Internal to the core (not installed with the public headers).
#pragma once

#include <cmath>

namespace motionkit::detail {

// a + b·ε with ε² = 0.
struct Dual {
  double v = 0.0;
  double d = 0.0;
};

inline double Value(double x) { return x; }
inline double Value(const Dual& x) { return x.v; }

inline Dual operator+(Dual a, Dual b) { return {a.v + b.v, a.d + b.d}; }
inline Dual operator-(Dual a, Dual b) { return {a.v - b.v, a.d - b.d}; }
inline Dual operator-(Dual a) { return {-a.v, -a.d}; }
inline Dual operator*(Dual a, Dual b) { return {a.v * b.v, a.d * b.v + a.v * b.d}; }
inline Dual operator*(double a, Dual b) { return {a * b.v, a * b.d}; }
inline Dual operator*(Dual a, double b) { return {a.v * b, a.d * b}; }
inline Dual operator+(Dual a, double b) { return {a.v + b, a.d}; }
inline Dual operator+(double a, Dual b) { return {a + b.v, b.d}; }
inline Dual operator-(double a, Dual b) { return {a - b.v, -b.d}; }
inline Dual operator-(Dual a, double b) { return {a.v - b, a.d}; }
inline Dual operator/(Dual a, Dual b) {
  const double q = a.v / b.v;
  return {q, (a.d - q * b.d) / b.v};
}
inline Dual operator/(Dual a, double b) { return {a.v / b, a.d / b}; }

inline Dual sqrt(Dual a) {
  const double s = std::sqrt(a.v);
  return {s, a.d / (2.0 * s)};
}
inline Dual sin(Dual a) { return {std::sin(a.v), std::cos(a.v) * a.d}; }
inline Dual cos(Dual a) { return {std::cos(a.v), -std::sin(a.v) * a.d}; }
inline Dual atan2(Dual y, Dual x) {
  return {std::atan2(y.v, x.v), (x.v * y.d - y.v * x.d) / (x.v * x.v + y.v * y.v)};
}

using std::atan2;
using std::cos;
using std::sin;
using std::sqrt;

template <class T>
struct Vec3 {
  T x, y, z;
};

// w + x i + y j + z k.
template <class T>
struct Quat {
  T w, x, y, z;
};

template <class T>
Vec3<T> operator*(const T& s, const Vec3<T>& v) {
  return {s * v.x, s * v.y, s * v.z};
}
template <class T>
Vec3<T> operator+(const Vec3<T>& a, const Vec3<T>& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
Vec3<T> operator-(const Vec3<T>& a, const Vec3<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
T Dot(const Vec3<T>& a, const Vec3<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

template <class T>
Quat<T> Conjugate(const Quat<T>& q) {
  return {q.w, -q.x, -q.y, -q.z};
}
template <class T>
Quat<T> Negated(const Quat<T>& q) {
  return {-q.w, -q.x, -q.y, -q.z};
}
template <class T>
T Dot(const Quat<T>& a, const Quat<T>& b) {
  return a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
}

template <class A, class B>
auto operator*(const Quat<A>& a, const Quat<B>& b) -> Quat<decltype(a.w * b.w)> {
  return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
          a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
          a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
          a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}

template <class T>
Quat<T> Normalized(const Quat<T>& q) {
  const T n = sqrt(Dot(q, q));
  return {q.w / n, q.x / n, q.y / n, q.z / n};
}

// Below this squared angle the trigonometric ratios below come from their
// Taylor series, which are even in the angle: no square root of something near
// zero (whose derivative is infinite) and no 0/0 as two rotations coincide.
// Five terms leave a truncation error under 1e-20 at the threshold.
constexpr double kSeriesBelow = 1e-4;

// Half-angle log of a rotation, shortest arc: for r = ±(cos a, sin a n) with
// a in [0, pi/2], a·n. r need not be exactly unit (atan2 ignores the scale).
template <class T>
Vec3<T> Log(Quat<T> r) {
  if (Value(r.w) < 0.0) r = Negated(r);
  const Vec3<T> v{r.x, r.y, r.z};
  const T s2 = Dot(v, v);
  T k;
  if (Value(s2) < kSeriesBelow * Value(r.w) * Value(r.w)) {
    // atan(x)/x with x = s/w.
    const T x2 = s2 / (r.w * r.w);
    k = (1.0 + x2 * (-1.0 / 3 + x2 * (1.0 / 5 + x2 * (-1.0 / 7 + x2 * (1.0 / 9))))) / r.w;
  } else {
    const T s = sqrt(s2);
    k = atan2(s, r.w) / s;
  }
  return k * v;
}

// Inverse of Log: (cos |v|, sin|v| v/|v|).
template <class T>
Quat<T> Exp(const Vec3<T>& v) {
  const T p2 = Dot(v, v);
  T c, sinc;
  if (Value(p2) < kSeriesBelow) {
    c = 1.0 + p2 * (-1.0 / 2 + p2 * (1.0 / 24 + p2 * (-1.0 / 720 + p2 * (1.0 / 40320))));
    sinc = 1.0 + p2 * (-1.0 / 6 + p2 * (1.0 / 120 + p2 * (-1.0 / 5040 + p2 * (1.0 / 362880))));
  } else {
    const T p = sqrt(p2);
    c = cos(p);
    sinc = sin(p) / p;
  }
  return {c, sinc * v.x, sinc * v.y, sinc * v.z};
}

// u·l with u a Dual (time-dependent) or a double and l fixed.
template <class T>
Vec3<T> Scaled(const T& u, const Vec3<double>& l) {
  return {u * l.x, u * l.y, u * l.z};
}

// a·exp(u·log(a⁻¹ b)): the shortest arc from a (u = 0) to b (u = 1) at
// constant angular speed; a and b unit.
template <class T>
Quat<T> SlerpOf(const Quat<T>& a, const Quat<T>& b, const T& u) {
  return a * Exp(u * Log(Conjugate(a) * b));
}

}  // namespace motionkit::detail
