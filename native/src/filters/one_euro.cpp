// The One-Euro filter (Casiez, Roussel and Vogel, CHI 2012): exponential
// smoothing whose cut-off rises with the smoothed speed of the signal, so that
// slow motion is steadied and fast motion followed without lag. Causal: each
// output depends only on the samples up to it, for streamed or live data.
#include <cmath>

#include "../so3.hpp"
#include "filter_internal.hpp"

namespace motionkit::internal {
namespace {

// The filter's state between samples: the speed estimate and the two factors
// that do not depend on it.
struct OneEuroState {
  explicit OneEuroState(const FilterSettings& settings)
      : settings_(settings), speed_alpha_(OneEuroAlpha(settings.d_cutoff, settings.fps)) {}

  // The smoothing factor for a sample whose unsmoothed speed is `speed`.
  double Alpha(double speed) {
    speed_ = speed_alpha_ * speed + (1.0 - speed_alpha_) * speed_;
    return OneEuroAlpha(settings_.min_cutoff + settings_.beta * std::abs(speed_), settings_.fps);
  }

 private:
  const FilterSettings& settings_;
  double speed_alpha_;
  double speed_ = 0.0;
};

}  // namespace

double OneEuroAlpha(double cutoff, double fps) {
  const double tau = 1.0 / (2.0 * kPi * cutoff), period = 1.0 / fps;
  return 1.0 / (1.0 + tau / period);
}

void OneEuroFilter(const FilterSettings& settings, const double* x, Eigen::Index n, double* out) {
  if (n < 1) return;
  OneEuroState state(settings);
  out[0] = x[0];
  for (Eigen::Index i = 1; i < n; ++i) {
    const double alpha = state.Alpha((x[i] - out[i - 1]) * settings.fps);
    out[i] = alpha * x[i] + (1.0 - alpha) * out[i - 1];
  }
}

void OneEuroRotations(const FilterSettings& settings, const Eigen::Quaterniond* q, Eigen::Index n,
                      Eigen::Quaterniond* out) {
  if (n < 1) return;
  OneEuroState state(settings);
  out[0] = q[0];
  for (Eigen::Index i = 1; i < n; ++i) {
    // Slerp from the last output towards the sample, along the shorter arc.
    const Eigen::Vector3d step = RotationVector(out[i - 1].conjugate() * q[i]);
    const double alpha = state.Alpha(step.norm() * settings.fps);
    out[i] = (out[i - 1] * FromRotationVector(alpha * step)).normalized();
  }
}

}  // namespace motionkit::internal
