#include "motionkit/rotation.hpp"

#include <algorithm>
#include <string>
#include <thread>

#include "parallel.hpp"

#include <cmath>
#include "so3.hpp"

namespace motionkit {
namespace {

using internal::kPi;
constexpr double kTwoPi = 2.0 * kPi;

// Below this middle-angle distance from +-pi/2 (radians) the first and last
// angles are not separable and the last one is set to 0. The quaternion method
// below stays accurate much closer to the lock than matrix formulas do, so the
// threshold only needs to keep the split well defined; at 1e-9 the rotation
// it returns differs from the input by at most ~3e-9 rad.
constexpr double kGimbalEpsilon = 1e-9;

struct OrderInfo {
  const char* name;
  const char* blender;
  int axis[3];
};

// Indexed by EulerOrder.
constexpr OrderInfo kOrders[] = {
    {"XYZ", "ZYX", {0, 1, 2}}, {"XZY", "YZX", {0, 2, 1}}, {"YXZ", "ZXY", {1, 0, 2}},
    {"YZX", "XZY", {1, 2, 0}}, {"ZXY", "YXZ", {2, 0, 1}}, {"ZYX", "XYZ", {2, 1, 0}},
};

const OrderInfo& Info(EulerOrder order) { return kOrders[static_cast<int>(order)]; }

// Into (-pi, pi]; inputs are within (-3 pi, 3 pi].
double WrapPi(double angle) {
  if (angle > kPi) return angle - kTwoPi;
  if (angle <= -kPi) return angle + kTwoPi;
  return angle;
}

Eigen::Matrix3d AxisMatrix(int axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  Eigen::Matrix3d m;
  switch (axis) {
    case 0:
      m << 1, 0, 0, 0, c, -s, 0, s, c;
      break;
    case 1:
      m << c, 0, s, 0, 1, 0, -s, 0, c;
      break;
    default:
      m << c, -s, 0, s, c, 0, 0, 0, 1;
      break;
  }
  return m;
}

Eigen::Quaterniond AxisQuaternion(int axis, double angle) {
  const double c = std::cos(0.5 * angle), s = std::sin(0.5 * angle);
  Eigen::Quaterniond q(c, 0.0, 0.0, 0.0);
  q.vec()[axis] = s;
  return q;
}

// The alternate triple of a Tait-Bryan rotation: R_i(a0 + pi) R_j(pi - a1)
// R_k(a2 + pi) equals R_i(a0) R_j(a1) R_k(a2).
Eigen::Vector3d Alternate(const Eigen::Vector3d& a) {
  return Eigen::Vector3d(WrapPi(a[0] + kPi), WrapPi(kPi - a[1]), WrapPi(a[2] + kPi));
}

// Each angle moved by whole turns to lie within pi of `previous`.
Eigen::Vector3d NearestTurns(Eigen::Vector3d angles, const Eigen::Vector3d& previous) {
  for (int k = 0; k < 3; ++k) {
    const double d = angles[k] - previous[k];
    if (d > kPi || d < -kPi) angles[k] -= kTwoPi * std::floor(d / kTwoPi + 0.5);
  }
  return angles;
}

double Distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return (a - b).cwiseAbs().sum();
}

// Principal angles from a unit quaternion, with a flag for gimbal lock.
//
// Method: E. Bernardes and S. Viollet, "Quaternion to Euler angles
// conversion: a direct, general and computationally efficient method",
// PLoS ONE 17(11), 2022 (the method scipy's Rotation.as_euler uses). Our
// intrinsic order (p0, p1, p2) is the extrinsic sequence (p2, p1, p0) with
// the angles reversed; the quaternion is permuted so that the middle angle
// comes from one atan2 of two norms and the outer ones from half sums and
// half differences, which stay accurate right up to the lock.
Eigen::Vector3d FromUnitQuaternion(const Eigen::Quaterniond& q, EulerOrder order, bool* locked) {
  const OrderInfo& info = Info(order);
  const int i = info.axis[2];  // first extrinsic axis
  const int j = info.axis[1];
  const int k = info.axis[0];
  const double sign = (i - j) * (j - k) * (k - i) / 2;  // Levi-Civita symbol of (i, j, k)
  const double w = q.w();
  const double v[3] = {q.x(), q.y(), q.z()};
  const double a = w - v[j];
  const double b = v[i] + sign * v[k];
  const double c = v[j] + w;
  const double d = sign * v[k] - v[i];

  const double middle = 2.0 * std::atan2(std::hypot(c, d), std::hypot(a, b));
  const double half_sum = std::atan2(b, a);
  const double half_diff = std::atan2(d, c);

  Eigen::Vector3d angles;
  angles[1] = middle - 0.5 * kPi;
  if (std::abs(middle) <= kGimbalEpsilon) {
    *locked = true;
    angles[0] = sign * 2.0 * half_sum;
    angles[2] = 0.0;
  } else if (std::abs(middle - kPi) <= kGimbalEpsilon) {
    *locked = true;
    angles[0] = sign * 2.0 * half_diff;
    angles[2] = 0.0;
  } else {
    *locked = false;
    angles[0] = sign * (half_sum + half_diff);
    angles[2] = half_sum - half_diff;
  }
  angles[0] = WrapPi(angles[0]);
  angles[2] = WrapPi(angles[2]);
  return angles;
}

Eigen::Vector3d FromRotation(const Eigen::Matrix3d& rotation, EulerOrder order, bool* locked) {
  // Eigen's matrix-to-quaternion conversion picks the best-conditioned branch.
  return FromUnitQuaternion(Eigen::Quaterniond(rotation).normalized(), order, locked);
}

}  // namespace

std::optional<EulerOrder> ParseEulerOrder(std::string_view text) {
  for (int o = 0; o < 6; ++o) {
    if (text == kOrders[o].name) return static_cast<EulerOrder>(o);
  }
  return std::nullopt;
}

const char* EulerOrderName(EulerOrder order) { return Info(order).name; }

const char* BlenderEulerMode(EulerOrder order) { return Info(order).blender; }

int EulerAxis(EulerOrder order, int k) { return Info(order).axis[k]; }

Eigen::Matrix3d EulerToMatrix(const Eigen::Vector3d& radians, EulerOrder order) {
  const OrderInfo& info = Info(order);
  return AxisMatrix(info.axis[0], radians[0]) * AxisMatrix(info.axis[1], radians[1]) *
         AxisMatrix(info.axis[2], radians[2]);
}

Eigen::Quaterniond EulerToQuaternion(const Eigen::Vector3d& radians, EulerOrder order) {
  const OrderInfo& info = Info(order);
  return AxisQuaternion(info.axis[0], radians[0]) * AxisQuaternion(info.axis[1], radians[1]) *
         AxisQuaternion(info.axis[2], radians[2]);
}

Eigen::Vector3d MatrixToEuler(const Eigen::Matrix3d& rotation, EulerOrder order) {
  bool locked = false;
  return FromRotation(rotation, order, &locked);
}

Eigen::Vector3d QuaternionToEuler(const Eigen::Quaterniond& q, EulerOrder order) {
  bool locked = false;
  return FromUnitQuaternion(q.normalized(), order, &locked);
}

// Blender's mat3_normalized_to_compatible_eulO: both solutions, each moved by
// whole turns towards `previous` (compatible_eul, which since Blender 3.6 wraps
// every axis to within pi), then the one with the smaller sum of absolute
// differences, the principal one on a tie.
//
// At gimbal lock only a0 + a2 (or a0 - a2) is defined. Blender then zeroes
// one angle, which makes a curve jump; we keep the last angle at its previous
// value and give the rest to the first, so curves through the lock stay
// continuous. (Blender's lock test is also wider: |cos a1| < 3.75e-5 in single
// precision, where it zeroes the first angle; ours is |a1 -+ pi/2| <= 1e-9.)
Eigen::Vector3d MatrixToEulerCompatible(const Eigen::Matrix3d& rotation, EulerOrder order,
                                        const Eigen::Vector3d& previous) {
  // Eigen's matrix-to-quaternion conversion picks the best-conditioned branch.
  return QuaternionToEulerCompatible(Eigen::Quaterniond(rotation), order, previous);
}

Eigen::Vector3d QuaternionToEulerCompatible(const Eigen::Quaterniond& q, EulerOrder order,
                                            const Eigen::Vector3d& previous) {
  bool locked = false;
  const Eigen::Vector3d principal = FromUnitQuaternion(q.normalized(), order, &locked);
  if (locked) {
    // R_i(a0) R_j(+-pi/2) R_k(a2) = R_i(a0 + s a2) R_j(+-pi/2), where s is +1
    // for a cyclic order at +pi/2, and flips with either.
    const OrderInfo& info = Info(order);
    const bool cyclic = info.axis[1] == (info.axis[0] + 1) % 3;
    const double s = (cyclic ? 1.0 : -1.0) * (principal[1] > 0 ? 1.0 : -1.0);
    const Eigen::Vector3d kept(principal[0] - s * previous[2], principal[1], previous[2]);
    return NearestTurns(kept, previous);
  }
  const Eigen::Vector3d first = NearestTurns(principal, previous);
  const Eigen::Vector3d second = NearestTurns(Alternate(principal), previous);
  return Distance(first, previous) > Distance(second, previous) ? second : first;
}

Status QuaternionsToEulers(ConstMatrixView quaternions, EulerOrder order, Eigen::Ref<RowMatrixXd> out,
                           bool continuous, const Eigen::VectorXd& previous, int threads) {
  const Eigen::Index groups = quaternions.cols() / 4, rows = quaternions.rows();
  if (quaternions.cols() != 4 * groups || out.cols() != 3 * groups || out.rows() != rows) {
    return Status::Fail("quaternion_to_euler: quaternions (n, 4k) and out (n, 3k), with as many rows");
  }
  if (previous.size() != 0 && previous.size() != 3 * groups) {
    return Status::Fail("quaternion_to_euler: previous must hold 3 angles per quaternion group (" +
                        std::to_string(3 * groups) + "), not " + std::to_string(previous.size()));
  }
  for (Eigen::Index c = 0; c < groups; ++c) {
    for (Eigen::Index i = 0; i < rows; ++i) {
      const Eigen::Vector4d q = quaternions.row(i).segment<4>(4 * c).transpose();
      if (!internal::IsRotationQuaternion(q)) {
        return Status::Fail("quaternion_to_euler: quaternion " + std::to_string(i) +
                            (groups > 1 ? " of group " + std::to_string(c) : std::string()) +
                            " is zero or not finite");
      }
    }
  }
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  internal::ParallelFor(static_cast<int>(groups), threads, [&](int c) {
    Eigen::Vector3d last = previous.size() ? Eigen::Vector3d(previous.segment<3>(3 * c)) : Eigen::Vector3d::Zero();
    for (Eigen::Index i = 0; i < rows; ++i) {
      const Eigen::Vector4d q = quaternions.row(i).segment<4>(4 * c).transpose();
      const Eigen::Quaterniond unit = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
      last = continuous ? QuaternionToEulerCompatible(unit, order, last) : QuaternionToEuler(unit, order);
      out.row(i).segment<3>(3 * c) = last.transpose();
    }
  });
  return Status::Ok();
}

Status QuaternionChannels(ConstMatrixView quaternions, const Eigen::VectorXd& previous, Eigen::Ref<RowMatrixXd> out,
                          int threads) {
  const Eigen::Index bones = quaternions.cols() / 4, rows = quaternions.rows();
  if (quaternions.cols() != 4 * bones || out.rows() != 4 * bones || out.cols() != rows) {
    return Status::Fail("quaternion_channels: quaternions (n, 4k) and out (4k, n)");
  }
  if (previous.size() != 0 && previous.size() != 4 * bones) {
    return Status::Fail("quaternion_channels: previous must hold one quaternion per bone (4k values), or none");
  }
  if (!previous.allFinite()) {
    return Status::Fail("quaternion_channels: previous is not finite");
  }
  for (Eigen::Index i = 0; i < rows; ++i) {
    for (Eigen::Index c = 0; c < bones; ++c) {
      if (!internal::IsRotationQuaternion(quaternions.row(i).segment<4>(4 * c).transpose())) {
        return Status::Fail("quaternion_channels: quaternion " + std::to_string(i) + " of bone " +
                            std::to_string(c) + " is zero or not finite");
      }
    }
  }
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  internal::ParallelFor(static_cast<int>(bones), threads, [&](int c) {
    Eigen::Vector4d last = previous.size() != 0 ? Eigen::Vector4d(previous.segment<4>(4 * c))
                                                : Eigen::Vector4d(1.0, 0.0, 0.0, 0.0);
    for (Eigen::Index i = 0; i < rows; ++i) {
      Eigen::Vector4d q = quaternions.row(i).segment<4>(4 * c).transpose();
      if (q.dot(last) < 0.0) q = -q;
      for (int k = 0; k < 4; ++k) out(4 * c + k, i) = q[k];
      last = q;
    }
  });
  return Status::Ok();
}

}  // namespace motionkit
