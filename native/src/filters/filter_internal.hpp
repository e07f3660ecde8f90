// The filters' algorithms, one per file, and what the two jobs share (internal
// to native/src). Every algorithm reads a contiguous signal of n samples and
// writes n samples; scratch comes from the caller, sized once per thread.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
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

// Transfer function b / a (order + 1 coefficients each, a[0] = 1) and the
// state of a step's steady response (order values), as scipy's butter and
// lfilter_zi give them.
struct ButterworthDesign {
  std::vector<double> b, a, zi;
};
ButterworthDesign DesignButterworth(int order, double cutoff, double fps);
// Samples of odd extension at each end: scipy's default, shortened for short signals.
Eigen::Index ButterworthPadding(const ButterworthDesign& design, Eigen::Index n);
// scipy's filtfilt; scratch holds n + 2 ButterworthPadding(design, n) + order values.
void ButterworthFilter(const ButterworthDesign& design, const double* x, Eigen::Index n, double* out,
                       double* scratch);

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

 private:
  const FilterDesign& design_;
  std::vector<double> scratch_;
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
