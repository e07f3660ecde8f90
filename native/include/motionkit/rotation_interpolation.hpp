// Interpolating rotation keys on the unit-quaternion sphere (docs/resampling.md),
// with the naive Euler and axis-angle splines beside them for comparison.
//
// Conventions: quaternions are w x y z rows; q and -q are the same rotation,
// so each key is flipped into the hemisphere of the one before it and every
// pair is joined by its shorter arc. Tangents live in the tangent space of the
// key, as half-angle vectors v of the body-frame motion q(t) = q_i exp(v t)
// (angular velocity in the body frame is 2v). The log/exp used are
//   log(cos a, sin a n) = a n (a in [0, pi/2] after the hemisphere flip),
//   exp(a n) = (cos a, sin a n).
//
// Key tangents, for key i with neighbours i-1 and i+1 (Δ⁻ = t_i - t_{i-1},
// Δ⁺ = t_{i+1} - t_i, d⁻ = log(q_{i-1}⁻¹ q_i), d⁺ = log(q_i⁻¹ q_{i+1}), all
// expressed at q_i — a rotation's axis is the same in both frames):
//   Catmull-Rom            m_i = (d⁻ + d⁺) / (Δ⁻ + Δ⁺)
//   Kochanek-Bartels in    m⁻_i = (1-T)[(1+B)(1-C) d⁻ + (1-B)(1+C) d⁺] / (Δ⁻ + Δ⁺)
//                    out   m⁺_i = (1-T)[(1+B)(1+C) d⁻ + (1-B)(1-C) d⁺] / (Δ⁻ + Δ⁺)
// i.e. the chord Catmull-Rom of docs/resampling.md (y_{i+1} - y_{i-1}) / (x_{i+1} - x_{i-1})
// and Kochanek and Bartels' (1984) tangents with their time adjustment for
// uneven key spacing (2Δ/(Δ⁻ + Δ⁺) per side), written per unit time. With C =
// 0 the incoming and outgoing velocities agree, so the curve is C1 in time
// whatever the spacing; T = C = B = 0 is exactly Catmull-Rom. At the first and
// last key the missing neighbour is a mirror image of the one present (d⁻ =
// d⁺, Δ⁻ = Δ⁺), so an end tangent is the chord velocity (times (1-T)(1-BC)).
//
// Segment i (h = t_{i+1} - t_i, u = (t - t_i)/h):
//   kSlerp: q_i exp(u d⁺).
//   kCatmullRom, kKochanekBartels: the spherical cubic Bézier with control
//     points q_i, q_i exp(h m⁺_i / 3), q_{i+1} exp(-h m⁻_{i+1} / 3), q_{i+1},
//     evaluated by De Casteljau with slerps (six per sample); its end
//     velocities are exactly m⁺_i and m⁻_{i+1}.
//   kSquad: Shoemake's slerp(slerp(q_i, q_{i+1}, u), slerp(s⁺_i, s⁻_{i+1}, u),
//     2u(1-u)). Uneven spacing: each key gets separate outgoing and incoming
//     control quaternions, s⁺_i = q_i exp((h m_i - d⁺)/2) and
//     s⁻_{i+1} = q_{i+1} exp((d⁺ - h m_{i+1})/2), chosen so that the velocity at
//     each end of each segment is the Catmull-Rom m above. With even spacing
//     these are Shoemake's s_i = q_i exp(-(log(q_i⁻¹q_{i+1}) + log(q_i⁻¹q_{i-1}))/4);
//     with uneven spacing the curve stays C1 in time (plain squad is C1 only
//     in the per-segment parameter and its speed jumps at keys).
//   kEulerCatmullRom: keys to Euler angles in `euler_order` (rotation.hpp's
//     intrinsic convention), made continuous as Blender's to_euler(compat)
//     does, the scalar Catmull-Rom above per angle, then back to a quaternion.
//   kAxisAngleCatmullRom: keys to rotation vectors, each the equivalent one
//     (adding whole turns along its axis) closest to the one before, the
//     scalar Catmull-Rom per component, then back.
// With two keys, slerp, Catmull-Rom, KB(T, C, B all 0) and squad are the same
// curve: the slerp between them.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>

#include "motionkit/error.hpp"
#include "motionkit/rotation.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

enum class RotationInterpolant : std::uint8_t {
  kSlerp,
  kSquad,
  kCatmullRom,
  kKochanekBartels,
  kEulerCatmullRom,
  kAxisAngleCatmullRom,
};

// "slerp", "squad", "catmull-rom", "kochanek-bartels", "euler-catmull-rom",
// "axis-angle-catmull-rom", or nothing.
std::optional<RotationInterpolant> ParseRotationInterpolant(std::string_view text);
const char* RotationInterpolantName(RotationInterpolant kind);
// All names, comma separated, for error messages.
const char* RotationInterpolantNames();

// The shortest arc from q0 (u = 0) to q1 (u = 1) at constant angular speed;
// u outside [0, 1] continues along the same great circle. Inputs are
// normalised first (they must not be zero); the result is unit length. Stays
// accurate as q0 and q1 approach each other (no 0/0: the ratios of sines come
// from their series there) and at 180° (one of the two half turns).
Eigen::Quaterniond Slerp(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1, double u);

struct RotationInterpolationOptions {
  RotationInterpolant kind = RotationInterpolant::kSquad;
  EulerOrder euler_order = EulerOrder::kXYZ;  // for kEulerCatmullRom only
};

// Per-key tension, continuity and bias for kKochanekBartels; an empty view
// means 0 for every key. Other kinds ignore them.
struct KeyTcb {
  KeyTcb();
  KeyTcb(ConstVectorView tension_in, ConstVectorView continuity_in, ConstVectorView bias_in)
      : tension(tension_in), continuity(continuity_in), bias(bias_in) {}
  ConstVectorView tension;
  ConstVectorView continuity;
  ConstVectorView bias;
};

// Evaluates the interpolant at every eval time.
//   times:      n key times, strictly increasing, finite, n >= 1.
//   quats:      n x 4 keys, w x y z, any length but not zero, any signs.
//   eval_times: m times, finite, any order (increasing ones take a fast path:
//               no search, each segment set up once).
//   out:        m x 4, unit quaternions (to 1e-12). Each row takes the sign
//               nearer the row before (the first: the sign the computation
//               gives, that of the earlier key of its segment as given).
//   angular_velocity: empty, or m x 3 world-frame angular velocity ω in
//               radians per time unit, dq/dt = ½ ω ⊗ q. Computed by carrying
//               d/dt through the evaluation (forward-mode dual numbers), so it
//               is the exact derivative of the curve to rounding.
// Outside [t_0, t_{n-1}] the end rotation is held (ω = 0 there); at t_0 and
// t_{n-1} themselves ω is the curve's one-sided velocity. A time equal to a
// key time gives that key.
struct RotationInterpolateJob {
  RotationInterpolateJob(ConstVectorView times_in, ConstMatrixView quats_in,
                         ConstVectorView eval_times_in, Eigen::Ref<RowMatrixXd> out_in,
                         Eigen::Ref<RowMatrixXd> angular_velocity_in = NoAngularVelocity(),
                         const KeyTcb& tcb_in = KeyTcb())
      : times(times_in),
        quats(quats_in),
        eval_times(eval_times_in),
        out(out_in),
        angular_velocity(angular_velocity_in),
        tcb(tcb_in) {}

  ConstVectorView times;
  ConstMatrixView quats;
  ConstVectorView eval_times;
  Eigen::Ref<RowMatrixXd> out;
  Eigen::Ref<RowMatrixXd> angular_velocity;
  KeyTcb tcb;
  RotationInterpolationOptions options;

  // Names the key or eval time at fault.
  Status Validate() const;
  // Throws Error when Validate() fails. Allocates nothing except, for the
  // Euler and axis-angle kinds, an n x 3 table of key angles that is kept and
  // reused by later runs of the same job.
  void Run();

  // An empty output: no angular velocity wanted.
  static RowMatrixXd& NoAngularVelocity();

 private:
  std::vector<double> key_channels_;
};

}  // namespace motionkit
