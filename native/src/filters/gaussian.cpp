// Gaussian smoothing as scipy.ndimage.gaussian_filter1d (truncate 4, mode
// 'reflect'): the same kernel, normalised the same way, and the clip extended
// by its mirror image about its end samples' outer edges (d c b a | a b c d | d c b a).
#include <cmath>

#include "filter_internal.hpp"

namespace motionkit::internal {
namespace {

// Index into [0, n) of sample i of the clip reflected without end, whose
// period is 2n.
Eigen::Index Reflected(Eigen::Index i, Eigen::Index n) {
  const Eigen::Index period = 2 * n;
  i %= period;
  if (i < 0) i += period;
  return i < n ? i : period - 1 - i;
}

}  // namespace

std::vector<double> GaussianHalfKernel(double sigma) {
  const int radius = static_cast<int>(4.0 * sigma + 0.5);
  std::vector<double> full(static_cast<std::size_t>(2 * radius + 1));
  const double scale = -0.5 / (sigma * sigma);
  double sum = 0.0;
  for (int x = -radius; x <= radius; ++x) {
    const double weight = std::exp(scale * static_cast<double>(x) * static_cast<double>(x));
    full[static_cast<std::size_t>(x + radius)] = weight;
    sum += weight;
  }
  std::vector<double> half(static_cast<std::size_t>(radius + 1));
  for (int x = 0; x <= radius; ++x) half[static_cast<std::size_t>(x)] = full[static_cast<std::size_t>(x + radius)] / sum;
  return half;
}

void GaussianFilter(const std::vector<double>& half_kernel, const double* x, Eigen::Index n, double* out) {
  const Eigen::Index radius = static_cast<Eigen::Index>(half_kernel.size()) - 1;
  const double* w = half_kernel.data();
  for (Eigen::Index i = 0; i < n; ++i) {
    double sum = x[i] * w[0];
    if (i >= radius && i + radius < n) {
      for (Eigen::Index k = 1; k <= radius; ++k) sum += (x[i - k] + x[i + k]) * w[k];
    } else {
      for (Eigen::Index k = 1; k <= radius; ++k) sum += (x[Reflected(i - k, n)] + x[Reflected(i + k, n)]) * w[k];
    }
    out[i] = sum;
  }
}

}  // namespace motionkit::internal
