// SO(3) helpers the core's sources share (internal to native/src): pi, rotation vectors and unit
// quaternions, the checks that a quaternion is a rotation, and the small Cholesky the IK solver's effector-space systems use.
//
// A rotation vector here is the axis times the rotation's whole angle. quaternion_calculus.hpp's Log
// and Exp are the quaternion logarithm and exponential (half the angle), another map, used by the
// rotation interpolants' formulas: named apart so that the two are not confused.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace motionkit::internal {

inline constexpr double kPi = 3.14159265358979323846;

// The core's one test of a rotation given as a quaternion (Eigen's, or four numbers w x y z in any
// order). A unit quaternion: finite and of length 1 to within `tolerance`, which each caller sets by
// where its numbers come from (float32 sources such as Blender's bone matrices are unit only to a few
// 1e-6). NaN fails, since it compares false.
inline bool IsUnitQuaternion(const Eigen::Quaterniond& q, double tolerance) {
  return q.coeffs().allFinite() && std::abs(q.norm() - 1.0) <= tolerance;
}

// A rotation once normalised: finite and not zero. Callers that take quaternions of any length (and
// normalise them) refuse only these.
template <class Derived>
inline bool IsRotationQuaternion(const Eigen::MatrixBase<Derived>& wxyz) {
  return wxyz.allFinite() && wxyz.norm() > 1e-12;
}
inline bool IsRotationQuaternion(const Eigen::Quaterniond& q) { return IsRotationQuaternion(q.coeffs()); }

// Rotation vector (axis times the full angle) -> unit quaternion.
inline Eigen::Quaterniond FromRotationVector(const Eigen::Vector3d& v) {
  const double a = v.norm();
  // Both unconditionally, so that the compiler makes them one sincos call.
  const double sine = std::sin(0.5 * a), cosine = std::cos(0.5 * a);
  const double s = a < 1e-6 ? 0.5 - a * a / 48.0 : sine / a;  // sin(a/2) / a
  return Eigen::Quaterniond(cosine, s * v.x(), s * v.y(), s * v.z());
}

// Unit quaternion -> rotation vector, angle in [0, pi].
inline Eigen::Vector3d RotationVector(const Eigen::Quaterniond& q) {
  double w = q.w();
  Eigen::Vector3d v = q.vec();
  if (w < 0) {
    w = -w;
    v = -v;
  }
  const double s = v.norm();
  if (s < 1e-9) return (2.0 / std::max(w, 1e-300)) * v;
  return (2.0 * std::atan2(s, w) / s) * v;
}

// In-place Cholesky of a symmetric n x n row-major matrix (its lower
// triangle). False when it is not numerically positive definite.
inline bool Cholesky(double* a, int n) {
  for (int j = 0; j < n; ++j) {
    double d = a[j * n + j];
    for (int k = 0; k < j; ++k) d -= a[j * n + k] * a[j * n + k];
    if (!(d > 0.0) || !std::isfinite(d)) return false;
    d = std::sqrt(d);
    a[j * n + j] = d;
    for (int i = j + 1; i < n; ++i) {
      double s = a[i * n + j];
      for (int k = 0; k < j; ++k) s -= a[i * n + k] * a[j * n + k];
      a[i * n + j] = s / d;
    }
  }
  return true;
}

inline void CholeskySolve(const double* l, int n, double* x) {
  for (int i = 0; i < n; ++i) {
    double s = x[i];
    for (int k = 0; k < i; ++k) s -= l[i * n + k] * x[k];
    x[i] = s / l[i * n + i];
  }
  for (int i = n - 1; i >= 0; --i) {
    double s = x[i];
    for (int k = i + 1; k < n; ++k) s -= l[k * n + i] * x[k];
    x[i] = s / l[i * n + i];
  }
}

}  // namespace motionkit::internal
