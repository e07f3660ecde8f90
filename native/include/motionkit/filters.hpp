// Filters for sampled animation: scalar channels (locations, scales, any
// F-curve sampled once per frame) and rotations filtered on the sphere.
//
// Scalar kinds, each column an independent channel sampled at `fps`:
//   kButterworth: zero-phase low-pass in second-order sections,
//     scipy.signal.butter(order, cutoff, fs=fps, output='sos') run by
//     sosfiltfilt with odd padding of min(3 (order + 1), frames - 1) samples
//     (scipy's default padding, shortened for short clips).
//   kGaussian: scipy.ndimage.gaussian_filter1d(sigma, mode='reflect',
//     truncate=4), sigma in frames.
//   kMedian: running median of an odd window, the clip extended by its end
//     values (ndimage.median_filter(mode='nearest')); spikes go, steps stay.
//   kOneEuro: the One-Euro filter (Casiez, Roussel and Vogel, CHI 2012),
//     causal: its cut-off rises with the signal's smoothed speed, steady when
//     slow and responsive when fast.
//
// Rotations (w x y z per bone) are never filtered as Euler angles or as
// renormalised components: the scalar filter runs in the tangent space of a
// smooth reference (Lee and Shin 2002). The reference starts as the integral
// of the filtered angular velocities and is then corrected a few times by the
// filtered deviation v_t = log(R_t^-1 q_t), R_t <- R_t exp(filtered v_t). Every
// kind passes a constant, so a constant angular velocity passes unchanged and a
// constant-speed rotation comes back as it went in, at the clip's ends too
// (componentwise filtering would bend it there, since the scalar filters'
// end extensions do not continue a rotation). The median, which is not
// linear and does not settle under such corrections, takes each frame's window
// in the tangent space at that frame instead (for a scalar the same filter).
// One-Euro on rotations is its quaternion form: slerp towards each sample by
// the adaptive alpha.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

enum class FilterKind : std::uint8_t { kButterworth, kGaussian, kMedian, kOneEuro };

// "butterworth", "gaussian", "median", "one_euro".
std::optional<FilterKind> ParseFilterKind(std::string_view name);
const char* FilterKindName(FilterKind kind);

// Each kind reads only its own parameters.
struct FilterSettings {
  FilterKind kind = FilterKind::kButterworth;
  double fps = 30.0;  // samples per second
  // kButterworth: cut-off in Hz (below fps / 2) and order 1..8.
  double cutoff = 7.0;
  int order = 4;
  // kGaussian: standard deviation in frames (> 0, at most kMaxGaussianSigma).
  double sigma = 1.0;
  // kMedian: odd window length in frames, 3 up to the clip's length.
  int size = 5;
  // kOneEuro: cut-off at rest (Hz), speed coefficient, and the cut-off (Hz) of
  // the speed estimate.
  double min_cutoff = 1.0;
  double beta = 0.0;
  double d_cutoff = 1.0;

  // The kernel's length grows with sigma; beyond this a Gaussian is a mean.
  static constexpr double kMaxGaussianSigma = 10000.0;

  // Names the kind and the numbers at fault, for a clip of `frames` frames.
  Status Validate(Eigen::Index frames) const;
};

// Inputs:
//   values:   frames x channels, finite.
//   settings: the kind and its parameters.
// Output, caller-owned: filtered, frames x channels (may not alias values).
// Channels are spread over `threads` threads (0: every core).
struct FilterChannelsJob {
  FilterChannelsJob(ConstMatrixView values_in, const FilterSettings& settings_in,
                    Eigen::Ref<RowMatrixXd> filtered_out)
      : values(values_in), settings(settings_in), filtered(filtered_out) {}

  ConstMatrixView values;
  FilterSettings settings;
  Eigen::Ref<RowMatrixXd> filtered;
  int threads = 0;

  // Names the channel and frame of a value that is not finite.
  Status Validate() const;
  // Throws Error when Validate() fails. Allocates one channel's scratch per
  // thread.
  void Run();
};

// Inputs:
//   quaternions: frames x (4 * bones), each bone's w x y z per frame, unit to
//                within 1e-6 (either sign, mixed signs allowed).
//   settings:    the kind and its parameters, as for scalar channels.
// Output, caller-owned: filtered, frames x (4 * bones) unit quaternions, each
// bone's signs continuous from frame to frame, the first frame's sign that of
// the input's first frame. Bones are spread over `threads` threads (0: every
// core).
struct FilterRotationsJob {
  FilterRotationsJob(ConstMatrixView quaternions_in, const FilterSettings& settings_in,
                     Eigen::Ref<RowMatrixXd> filtered_out)
      : quaternions(quaternions_in), settings(settings_in), filtered(filtered_out) {}

  ConstMatrixView quaternions;
  FilterSettings settings;
  Eigen::Ref<RowMatrixXd> filtered;
  int threads = 0;

  // Tangent-space corrections at most, and the update (radians) below which
  // they stop early.
  static constexpr int kCorrections = 3;
  static constexpr double kConverged = 1e-12;

  // Names the bone and frame of a quaternion that is not unit or not finite.
  Status Validate() const;
  // Throws Error when Validate() fails. Allocates one bone's scratch per
  // thread.
  void Run();
};

}  // namespace motionkit
