#include "motionkit/rotation_interpolation.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "quaternion_calculus.hpp"
#include "so3.hpp"
#include "time_checks.hpp"

namespace motionkit {
namespace {

using detail::Conjugate;
using detail::Dot;
using detail::Dual;
using detail::Exp;
using detail::Log;
using detail::Negated;
using detail::Normalized;
using detail::Quat;
using detail::Scaled;
using detail::SlerpOf;
using detail::Vec3;

using internal::kPi;

constexpr const char* kNames[] = {"slerp",            "squad",
                                  "catmull-rom",      "kochanek-bartels",
                                  "euler-catmull-rom", "axis-angle-catmull-rom"};

Quat<double> FromEigen(const Eigen::Quaterniond& q) { return {q.w(), q.x(), q.y(), q.z()}; }

Quat<double> Aligned(const Quat<double>& q, const Quat<double>& reference) {
  return Dot(q, reference) < 0.0 ? Negated(q) : q;
}

Vec3<double> Times(double s, const Vec3<double>& v) { return {s * v.x, s * v.y, s * v.z}; }

struct Tcb {
  double tension = 0.0, continuity = 0.0, bias = 0.0;
};

// Incoming and outgoing velocities at a key from the displacements to and
// from its neighbours (see the header for the formulas).
void KeyTangents(const Vec3<double>& d_in, const Vec3<double>& d_out, double dt_in, double dt_out,
                 const Tcb& k, Vec3<double>* m_in, Vec3<double>* m_out) {
  const double scale = (1.0 - k.tension) / (dt_in + dt_out);
  const double c = k.continuity, b = k.bias;
  *m_in = Times(scale * (1 + b) * (1 - c), d_in) + Times(scale * (1 - b) * (1 + c), d_out);
  *m_out = Times(scale * (1 + b) * (1 + c), d_in) + Times(scale * (1 - b) * (1 - c), d_out);
}

template <class T>
Quat<T> AxisQuat(int axis, const T& angle) {
  const T c = detail::cos(0.5 * angle), s = detail::sin(0.5 * angle);
  Quat<T> q{c, 0.0 * angle, 0.0 * angle, 0.0 * angle};
  (axis == 0 ? q.x : axis == 1 ? q.y : q.z) = s;
  return q;
}

// One segment of the curve, set up once and evaluated at many times.
class Segment {
 public:
  Segment(const RotationInterpolateJob& job, const std::vector<double>& key_channels)
      : job_(job), channels_(key_channels), kind_(job.options.kind) {}

  Eigen::Index index() const { return index_; }

  void SetUp(Eigen::Index i) {
    index_ = i;
    t0_ = job_.times[i];
    h_ = job_.times[i + 1] - t0_;
    if (kind_ == RotationInterpolant::kEulerCatmullRom ||
        kind_ == RotationInterpolant::kAxisAngleCatmullRom) {
      SetUpChannels(i);
      return;
    }
    const Quat<double> a = Key(i);
    const Quat<double> b = Aligned(Key(i + 1), a);
    const Vec3<double> d = Log(Conjugate(a) * b);
    p0_ = a;
    l01_ = d;
    if (kind_ == RotationInterpolant::kSlerp) return;

    const Eigen::Index n = job_.times.size();
    // Tangents at both ends of the segment; a missing neighbour mirrors the
    // one present.
    Vec3<double> d_prev = d, d_next = d;
    double dt_prev = h_, dt_next = h_;
    if (i > 0) {
      d_prev = Log(Conjugate(Aligned(Key(i - 1), a)) * a);
      dt_prev = t0_ - job_.times[i - 1];
    }
    if (i + 2 < n) {
      d_next = Log(Conjugate(b) * Aligned(Key(i + 2), b));
      dt_next = job_.times[i + 2] - job_.times[i + 1];
    }
    const bool kb = kind_ == RotationInterpolant::kKochanekBartels;
    Vec3<double> unused, m_start, m_end;
    KeyTangents(d_prev, d, dt_prev, h_, kb ? KeyParameters(i) : Tcb(), &unused, &m_start);
    KeyTangents(d, d_next, h_, dt_next, kb ? KeyParameters(i + 1) : Tcb(), &m_end, &unused);

    if (kind_ == RotationInterpolant::kSquad) {
      const Quat<double> s_out = a * Exp(Times(0.5, Times(h_, m_start) - d));
      const Quat<double> s_in = b * Exp(Times(0.5, d - Times(h_, m_end)));
      p1_ = s_out;
      l12_ = Log(Conjugate(s_out) * s_in);
      return;
    }
    // Spherical Bézier. The end legs are the tangents themselves, not the
    // log of their exp, so that a leg longer than a quarter turn is kept.
    l01_ = Times(h_ / 3.0, m_start);
    l23_ = Times(h_ / 3.0, m_end);
    p1_ = a * Exp(l01_);
    p2_ = b * Exp(Times(-1.0, l23_));
    l12_ = Log(Conjugate(p1_) * p2_);
  }

  // The rotation at time t within the segment (not normalised); with T =
  // Dual, t's derivative part is 1 and the result's is dq/dt.
  template <class T>
  Quat<T> Evaluate(const T& t) const {
    const T u = (t - t0_) / h_;
    switch (kind_) {
      case RotationInterpolant::kSlerp:
        return p0_ * Exp(Scaled(u, l01_));
      case RotationInterpolant::kSquad: {
        const Quat<T> keys = p0_ * Exp(Scaled(u, l01_));
        const Quat<T> controls = p1_ * Exp(Scaled(u, l12_));
        const T weight = 2.0 * u * (1.0 - u);
        return SlerpOf(keys, controls, weight);
      }
      case RotationInterpolant::kCatmullRom:
      case RotationInterpolant::kKochanekBartels: {
        const Quat<T> a = p0_ * Exp(Scaled(u, l01_));
        const Quat<T> b = p1_ * Exp(Scaled(u, l12_));
        const Quat<T> c = p2_ * Exp(Scaled(u, l23_));
        return SlerpOf(SlerpOf(a, b, u), SlerpOf(b, c, u), u);
      }
      case RotationInterpolant::kEulerCatmullRom:
      case RotationInterpolant::kAxisAngleCatmullRom:
        break;
    }
    return EvaluateChannels(u);
  }

 private:
  Quat<double> Key(Eigen::Index i) const {
    const auto row = job_.quats.row(i);
    return Normalized(Quat<double>{row[0], row[1], row[2], row[3]});
  }

  Tcb KeyParameters(Eigen::Index i) const {
    Tcb k;
    if (job_.tcb.tension.size() > 0) k.tension = job_.tcb.tension[i];
    if (job_.tcb.continuity.size() > 0) k.continuity = job_.tcb.continuity[i];
    if (job_.tcb.bias.size() > 0) k.bias = job_.tcb.bias[i];
    return k;
  }

  double Channel(Eigen::Index key, int c) const {
    return channels_[static_cast<std::size_t>(3 * key + c)];
  }

  // Hermite data per channel: values and Catmull-Rom velocities at both ends.
  void SetUpChannels(Eigen::Index i) {
    const Eigen::Index n = job_.times.size();
    for (int c = 0; c < 3; ++c) {
      const double y0 = Channel(i, c), y1 = Channel(i + 1, c);
      const double chord = (y1 - y0) / h_;
      y0_[c] = y0;
      y1_[c] = y1;
      m0_[c] = i > 0 ? (y1 - Channel(i - 1, c)) / (job_.times[i + 1] - job_.times[i - 1]) : chord;
      m1_[c] = i + 2 < n ? (Channel(i + 2, c) - y0) / (job_.times[i + 2] - t0_) : chord;
    }
  }

  template <class T>
  Quat<T> EvaluateChannels(const T& u) const {
    const T u2 = u * u, u3 = u2 * u;
    const T h00 = 2.0 * u3 - 3.0 * u2 + 1.0, h01 = 3.0 * u2 - 2.0 * u3;
    const T h10 = (u3 - 2.0 * u2 + u) * h_, h11 = (u3 - u2) * h_;
    T v[3];
    for (int c = 0; c < 3; ++c) v[c] = h00 * y0_[c] + h01 * y1_[c] + h10 * m0_[c] + h11 * m1_[c];
    if (kind_ == RotationInterpolant::kAxisAngleCatmullRom) {
      return Exp(Vec3<T>{0.5 * v[0], 0.5 * v[1], 0.5 * v[2]});
    }
    const EulerOrder order = job_.options.euler_order;
    return AxisQuat(EulerAxis(order, 0), v[0]) * AxisQuat(EulerAxis(order, 1), v[1]) *
           AxisQuat(EulerAxis(order, 2), v[2]);
  }

  const RotationInterpolateJob& job_;
  const std::vector<double>& channels_;
  RotationInterpolant kind_;
  Eigen::Index index_ = -1;
  double t0_ = 0.0, h_ = 1.0;
  Quat<double> p0_{1, 0, 0, 0}, p1_{1, 0, 0, 0}, p2_{1, 0, 0, 0};
  Vec3<double> l01_{0, 0, 0}, l12_{0, 0, 0}, l23_{0, 0, 0};
  double y0_[3] = {}, y1_[3] = {}, m0_[3] = {}, m1_[3] = {};
};

// Euler angles or rotation vectors of the keys, each continuous with the one
// before, into channels (n x 3, row-major).
void KeyChannels(const RotationInterpolateJob& job, std::vector<double>* channels) {
  const Eigen::Index n = job.times.size();
  channels->resize(static_cast<std::size_t>(3 * n));
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector4d row = job.quats.row(i).transpose();
    const Eigen::Quaterniond q = Eigen::Quaterniond(row[0], row[1], row[2], row[3]).normalized();
    Eigen::Vector3d value;
    if (job.options.kind == RotationInterpolant::kEulerCatmullRom) {
      value = i == 0 ? QuaternionToEuler(q, job.options.euler_order)
                     : MatrixToEulerCompatible(q.toRotationMatrix(), job.options.euler_order, previous);
    } else {
      const Vec3<double> half = Log(FromEigen(q));
      value = 2.0 * Eigen::Vector3d(half.x, half.y, half.z);
      const double angle = value.norm();
      if (i > 0 && angle > 0.0) {
        const Eigen::Vector3d axis = value / angle;
        const double turns = std::round((axis.dot(previous) - angle) / (2.0 * kPi));
        value = (angle + 2.0 * kPi * turns) * axis;
      }
    }
    for (int c = 0; c < 3; ++c) (*channels)[static_cast<std::size_t>(3 * i + c)] = value[c];
    previous = value;
  }
}

std::string Where(Eigen::Index i) { return std::to_string(i); }

}  // namespace

std::optional<RotationInterpolant> ParseRotationInterpolant(std::string_view text) {
  for (int k = 0; k < 6; ++k) {
    if (text == kNames[k]) return static_cast<RotationInterpolant>(k);
  }
  return std::nullopt;
}

const char* RotationInterpolantName(RotationInterpolant kind) {
  return kNames[static_cast<int>(kind)];
}

const char* RotationInterpolantNames() {
  return "slerp, squad, catmull-rom, kochanek-bartels, euler-catmull-rom, axis-angle-catmull-rom";
}

Eigen::Quaterniond Slerp(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1, double u) {
  const Quat<double> a = Normalized(FromEigen(q0));
  const Quat<double> r = Normalized(SlerpOf(a, Normalized(FromEigen(q1)), u));
  return Eigen::Quaterniond(r.w, r.x, r.y, r.z);
}

namespace {
const Eigen::VectorXd& NoValues() {
  static const Eigen::VectorXd empty;
  return empty;
}
}  // namespace

KeyTcb::KeyTcb() : KeyTcb(NoValues(), NoValues(), NoValues()) {}

RowMatrixXd& RotationInterpolateJob::NoAngularVelocity() {
  static RowMatrixXd empty(0, 3);
  return empty;
}

Status RotationInterpolateJob::Validate() const {
  const Eigen::Index n = times.size();
  const Eigen::Index m = eval_times.size();
  if (n < 1) return Status::Fail("rotation interpolation: no keys");
  if (quats.rows() != n || quats.cols() != 4) {
    return Status::Fail("rotation interpolation: quats must be " + std::to_string(n) +
                        " x 4 (w x y z per key), got " + std::to_string(quats.rows()) + " x " +
                        std::to_string(quats.cols()));
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!internal::TimeInOrder(times.data(), i)) {
      return internal::TimeOrderFailure(times.data(), i, "rotation interpolation: ", internal::kKeyTimes);
    }
    const Eigen::Vector4d q = quats.row(i).transpose();
    if (!q.allFinite()) {
      return Status::Fail("rotation interpolation: quaternion of key " + Where(i) + " (time " +
                          std::to_string(times[i]) + ") is not finite");
    }
    if (!internal::IsRotationQuaternion(q)) {  // finite, so only a zero one fails here
      return Status::Fail("rotation interpolation: quaternion of key " + Where(i) + " (time " +
                          std::to_string(times[i]) + ") is zero");
    }
  }
  const ConstVectorView* parameters[3] = {&tcb.tension, &tcb.continuity, &tcb.bias};
  const char* parameter_names[3] = {"tension", "continuity", "bias"};
  for (int p = 0; p < 3; ++p) {
    const ConstVectorView& values = *parameters[p];
    if (values.size() == 0) continue;
    if (values.size() != n) {
      return Status::Fail(std::string("rotation interpolation: ") + parameter_names[p] + " has " +
                          std::to_string(values.size()) + " values for " + std::to_string(n) +
                          " keys (pass one per key, or none for 0)");
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!std::isfinite(values[i])) {
        return Status::Fail(std::string("rotation interpolation: ") + parameter_names[p] +
                            " of key " + Where(i) + " is not finite");
      }
    }
  }
  for (Eigen::Index j = 0; j < m; ++j) {
    if (!std::isfinite(eval_times[j])) {
      return Status::Fail("rotation interpolation: eval time " + Where(j) + " is not finite");
    }
  }
  if (out.rows() != m || out.cols() != 4) {
    return Status::Fail("rotation interpolation: out must be " + std::to_string(m) + " x 4, got " +
                        std::to_string(out.rows()) + " x " + std::to_string(out.cols()));
  }
  if (angular_velocity.size() != 0 && (angular_velocity.rows() != m || angular_velocity.cols() != 3)) {
    return Status::Fail("rotation interpolation: angular_velocity must be empty or " +
                        std::to_string(m) + " x 3, got " + std::to_string(angular_velocity.rows()) +
                        " x " + std::to_string(angular_velocity.cols()));
  }
  return Status::Ok();
}

void RotationInterpolateJob::Run() {
  Validate().ThrowIfFailed();
  const Eigen::Index n = times.size();
  const Eigen::Index m = eval_times.size();
  const bool want_velocity = angular_velocity.size() != 0;
  const RotationInterpolant kind = options.kind;
  if (n > 1 && (kind == RotationInterpolant::kEulerCatmullRom ||
                kind == RotationInterpolant::kAxisAngleCatmullRom)) {
    KeyChannels(*this, &key_channels_);
  }
  Segment segment(*this, key_channels_);
  const double first = times[0], last = times[n - 1];
  Quat<double> previous{0, 0, 0, 0};
  for (Eigen::Index j = 0; j < m; ++j) {
    const double t = eval_times[j];
    Quat<double> q, dq{0, 0, 0, 0};
    if (n == 1 || t < first || t > last) {
      const auto row = quats.row(t < last ? 0 : n - 1);
      q = Normalized(Quat<double>{row[0], row[1], row[2], row[3]});
    } else {
      // Increasing times stay in the segment they were in or step to the next.
      Eigen::Index i = segment.index();
      if (!(i >= 0 && times[i] <= t && (t < times[i + 1] || i + 2 == n))) {
        if (i >= 0 && i + 2 < n && times[i + 1] <= t && t < times[i + 2]) {
          ++i;
        } else {
          // The last key time belongs to the last segment (its end).
          i = std::min<Eigen::Index>(
              (std::upper_bound(times.data(), times.data() + n, t) - times.data()) - 1, n - 2);
        }
        segment.SetUp(i);
      }
      if (want_velocity) {
        const Quat<Dual> r = Normalized(segment.Evaluate(Dual{t, 1.0}));
        q = {r.w.v, r.x.v, r.y.v, r.z.v};
        dq = {r.w.d, r.x.d, r.y.d, r.z.d};
      } else {
        q = Normalized(segment.Evaluate(t));
      }
    }
    if (j > 0 && Dot(q, previous) < 0.0) {
      q = Negated(q);
      dq = Negated(dq);
    }
    previous = q;
    out.row(j) << q.w, q.x, q.y, q.z;
    if (want_velocity) {
      // ω = 2 q̇ q⁻¹; its scalar part vanishes because |q| = 1.
      const Quat<double> w = dq * Conjugate(q);
      angular_velocity.row(j) << 2.0 * w.x, 2.0 * w.y, 2.0 * w.z;
    }
  }
}

}  // namespace motionkit
