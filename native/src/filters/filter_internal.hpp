// The filters' algorithms, one per file, and what the two jobs share (internal
// to native/src). Every algorithm reads a contiguous signal of n samples and
// writes n samples; scratch comes from the caller, sized once per thread.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../parallel.hpp"
#include "motionkit/filters.hpp"

namespace motionkit::internal {

// A number as the filters' messages show it: 15, 7.5, nan.
inline std::string Number(double value) {
  std::ostringstream text;
  text.precision(10);
  text << value;
  return text.str();
}

// Second-order sections b0 b1 b2 a0 a1 a2 (a0 = 1), the state of a step's
// steady response per section, and the taps that set the padding, as scipy's
// butter(output='sos'), sosfilt_zi and sosfiltfilt give them.
struct ButterworthDesign {
  std::vector<std::array<double, 6>> sections;
  std::vector<std::array<double, 2>> zi;
  int taps = 0;
};
ButterworthDesign DesignButterworth(int order, double cutoff, double fps);
// Samples of odd extension at each end: sosfiltfilt's default 3 taps, shortened for short signals.
Eigen::Index ButterworthPadding(const ButterworthDesign& design, Eigen::Index n);
// Channels the Butterworth filter runs side by side: independent recurrences
// that the processor overlaps.
inline constexpr int kLanes = 4;
// scipy's sosfiltfilt of `lanes` (1..kLanes) channels at once: sample i of
// channel l at x[i x_stride + l], written to out[i out_stride + l]; scratch
// holds kLanes (n + 2 ButterworthPadding(design, n)) values.
void ButterworthFilter(const ButterworthDesign& design, const double* x, Eigen::Index x_stride, int lanes,
                       Eigen::Index n, double* out, Eigen::Index out_stride, double* scratch);

// Weights of the centre and of offsets 1..radius (radius = int(4 sigma + 0.5)), summing to 1 over -radius..radius.
std::vector<double> GaussianHalfKernel(double sigma);
// ndimage.gaussian_filter1d with mode 'reflect'.
void GaussianFilter(const std::vector<double>& half_kernel, const double* x, Eigen::Index n, double* out);

// ndimage.median_filter with mode 'nearest' for an odd size; window holds size values.
void MedianFilter(int size, const double* x, Eigen::Index n, double* out, double* window);
// One pass of the median in the tangent space at each frame's centre (q itself
// at first), moving the centres; the largest move (radians). q sign-continuous,
// window holds 3 size values.
double MedianRotations(int size, const Eigen::Quaterniond* q, Eigen::Index n, Eigen::Quaterniond* centre,
                       double* window);

// The One-Euro filter's smoothing factor for a cut-off (Hz) at fps samples per second.
double OneEuroAlpha(double cutoff, double fps);
void OneEuroFilter(const FilterSettings& settings, const double* x, Eigen::Index n, double* out);
// Its quaternion form; q sign-continuous, out unit and sign-continuous with q.
void OneEuroRotations(const FilterSettings& settings, const Eigen::Quaterniond* q, Eigen::Index n,
                      Eigen::Quaterniond* out);

// What a job designs once and its threads share.
struct FilterDesign {
  FilterSettings settings;
  ButterworthDesign butterworth;
  std::vector<double> gaussian;
};
FilterDesign DesignFilter(const FilterSettings& settings);

// One thread's filter of one kind: the shared design and scratch for signals of
// up to `frames` samples, any length from 1 (a median window or a Gaussian
// kernel longer than the signal extends it as the kind does).
class ScalarFilter {
 public:
  ScalarFilter(const FilterDesign& design, Eigen::Index frames);
  void Apply(const double* in, Eigen::Index n, double* out);
  // `lanes` (1..kLanes) channels at once: sample i of channel l at
  // in[i in_stride + l], written to out[i out_stride + l].
  void Apply(const double* in, Eigen::Index in_stride, int lanes, Eigen::Index n, double* out,
             Eigen::Index out_stride);

 private:
  const FilterDesign& design_;
  std::vector<double> scratch_, in_, out_;
};

// work(begin, end) over ranges covering [0, count), one range per thread
// (threads 0: every core), so that each range sizes its scratch once.
template <class Work>
void ForEachRange(Eigen::Index count, int threads, const Work& work) {
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const Eigen::Index ranges = std::max<Eigen::Index>(1, std::min<Eigen::Index>(count, threads));
  ParallelFor(static_cast<int>(ranges), threads, [&](int r) {
    work(count * r / ranges, count * (r + 1) / ranges);
  });
}

}  // namespace motionkit::internal
