// Key reduction: the fewest keys whose curve stays within a tolerance of a
// densely sampled original.
//
// The fitted curve is what Blender draws for Bézier keys with FREE handles at
// one third of each segment: between keys a and b (h = t_b - t_a,
// u = (t - t_a)/h) each channel is the cubic Hermite
//   y(u) = H0 y_a + H1 y_b + h (H2 s⁺_a + H3 s⁻_b)
// with the key values taken from the samples and a separate outgoing slope s⁺
// and incoming slope s⁻ at every key (value per time unit). For Blender, the
// right handle of key a is at (t_a + h/3, y_a + s⁺_a h/3) and the left handle
// of key b at (t_b - h/3, y_b - s⁻_b h/3).
//
// Algorithm: greedy furthest reach. From each key a, the end b is searched
// exponentially (a+2, a+4, a+8, ...) and then by bisection; for a candidate
// segment the two end slopes are fitted per channel by linear least squares
// over the samples strictly inside it (the Hermite curve is linear in them once
// the end values are fixed; when fewer than two samples lie inside, a tiny
// ridge picks the solution nearest the chord slope), and the segment is accepted when
// every inside sample is within tolerance. Each sample is visited O(log L)
// times for a segment of L samples, so the whole is O(m log m) for m samples.
// Greedy reach with bisection is not guaranteed minimal (acceptance need not
// be monotone in b), but every segment it returns has been checked.
//
// Guarantee: the result is within tolerance at every input sample, nothing
// more. Callers that want it within tolerance everywhere pass samples denser
// than the keys they expect (4 to 10 per frame, say).
#pragma once

#include <cstdint>
#include <vector>

#include "motionkit/error.hpp"
#include "motionkit/rotation.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

enum class KeyToleranceMode : std::uint8_t {
  // Every channel within `tolerance` of its sample (scalar channels, or d
  // channels that share key times such as a location).
  kAbsolute,
  // Four channels w x y z that Blender interpolates one by one and normalises
  // when it poses the bone. Error: the angle (radians) between the normalised
  // reconstruction and the sample's rotation (q and -q alike).
  kQuaternion,
  // Three Euler channels (radians) in the letter order of `euler_order`, the
  // intrinsic convention of rotation.hpp: column k is the angle about axis
  // EulerAxis(euler_order, k). Error: the angle between the rotations.
  // Blender: a bone with rotation_mode 'XYZ' means Rz(z) Ry(y) Rx(x), which is
  // euler_order kZYX with columns (z, y, x) = rotation_euler reversed; in
  // general euler_order is rotation_mode with its letters reversed (see
  // BlenderEulerMode) and column k is rotation_euler[EulerAxis(euler_order, k)].
  // The fit is per channel and the error per sample, so the column order
  // changes nothing but the layout of the slopes.
  kEuler,
};

using IndexVectorView = Eigen::Ref<Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1>>;

// Inputs:
//   times:     m sample times, strictly increasing, finite, m >= 1.
//   values:    m x d samples, finite (d = 4 for kQuaternion, whose samples
//              must not be zero; d = 3 for kEuler).
//   tolerance: finite, >= 0 (radians for the rotation modes).
// Outputs, caller-owned and sized for the worst case (every sample a key):
//   key_indices: m; the first key_count entries are the chosen sample
//              indices, increasing, always 0 and m - 1.
//   slopes_in, slopes_out: m x d; rows [0, key_count) hold each key's
//              incoming and outgoing slopes. The first key's incoming slope
//              repeats its outgoing one and the last key's outgoing slope its
//              incoming one (their handles lie outside the curve).
//   key_count: set by Run().
// Key values are the samples: values.row(key_indices[k]).
struct KeyReductionJob {
  KeyReductionJob(ConstVectorView times_in, ConstMatrixView values_in, double tolerance_in,
                  IndexVectorView key_indices_out, Eigen::Ref<RowMatrixXd> slopes_in_out,
                  Eigen::Ref<RowMatrixXd> slopes_out_out)
      : times(times_in),
        values(values_in),
        tolerance(tolerance_in),
        key_indices(key_indices_out),
        slopes_in(slopes_in_out),
        slopes_out(slopes_out_out) {}

  ConstVectorView times;
  ConstMatrixView values;
  double tolerance;
  KeyToleranceMode mode = KeyToleranceMode::kAbsolute;
  EulerOrder euler_order = EulerOrder::kXYZ;  // kEuler only
  // Keys are chosen among every stride-th sample (and the last): with samples
  // taken several times per frame, a stride of that many keeps keys on frames
  // while the tolerance is still checked at every sample.
  Eigen::Index stride = 1;
  IndexVectorView key_indices;
  Eigen::Ref<RowMatrixXd> slopes_in;
  Eigen::Ref<RowMatrixXd> slopes_out;
  Eigen::Index key_count = 0;

  // Names the sample and channel at fault.
  Status Validate() const;
  // Throws Error when Validate() fails. Allocates only a 6 x d scratch row,
  // once per run.
  void Run();

 private:
  bool FitSegment(Eigen::Index a, Eigen::Index b, double* slope_a, double* slope_b);
  bool WithinTolerance(Eigen::Index a, Eigen::Index b, const double* slope_a,
                       const double* slope_b) const;
  std::vector<double> scratch_;
};

}  // namespace motionkit
