// Butterworth low-pass in second-order sections, designed and run as scipy does
// (signal.butter(..., output='sos'), then sosfiltfilt with odd padding). A
// high-order, low cut-off design is ill-conditioned as one transfer function
// (its coefficients lose digits to the poles' clustering near z = 1); as a
// cascade of biquads each section's coefficients hold its own pair of poles
// to rounding, so the result does not depend on the machine's last bits.
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <utility>

#include "../so3.hpp"
#include "filter_internal.hpp"

namespace motionkit::internal {
namespace {

using Complex = std::complex<double>;

// The z-plane poles of an order-N Butterworth low-pass, as buttap, lp2lp_zpk and
// bilinear_zpk make them (scipy normalises to fs = 2, so the bilinear
// transform's 2 fs is 4), and the gain that puts its response at 1 at 0 Hz.
// Analog poles -exp(i pi m / 2N) for m = -N+1, -N+3, ..., N-1 at the
// prewarped cut-off; their N zeros at infinity map to z = -1.
std::vector<Complex> ButterworthPoles(int order, double cutoff, double fps, double& gain) {
  const double warped = 4.0 * std::tan(kPi * cutoff / fps);
  std::vector<Complex> poles;
  Complex denominator(1.0, 0.0);
  for (int i = 0; i < order; ++i) {
    const double angle = kPi * (-order + 1 + 2 * i) / (2.0 * order);
    // The middle pole of an odd order is real: its imaginary part exactly 0.
    const Complex analog = 2 * i + 1 == order ? Complex(-warped, 0.0)
                                              : Complex(-std::cos(angle) * warped, -std::sin(angle) * warped);
    denominator *= 4.0 - analog;
    poles.push_back((4.0 + analog) / (4.0 - analog));
  }
  gain = std::pow(warped, order) / denominator.real();
  return poles;
}

// numpy.poly of two roots (conjugates or both real): 1, -(r1 + r2), r1 r2, real.
std::array<double, 3> Quadratic(Complex r1, Complex r2) {
  return {1.0, -(r1 + r2).real(), (r1 * r2).real()};
}

// The index of the element of `values` nearest `to`, among those that `take`.
template <class Take>
std::size_t Nearest(const std::vector<Complex>& values, Complex to, const Take& take) {
  std::size_t best = values.size();
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (take(values[i]) && (best == values.size() || std::abs(values[i] - to) < std::abs(values[best] - to))) best = i;
  }
  return best;
}

Complex TakeAt(std::vector<Complex>& values, std::size_t i) {
  const Complex value = values[i];
  values.erase(values.begin() + static_cast<std::ptrdiff_t>(i));
  return value;
}

bool IsReal(Complex value) { return value.imag() == 0.0; }

// zpk2sos(pairing='nearest') for zeros that are all real (-1, and 0 for an odd
// order): one pole of each conjugate pair (positive imaginary part) and the
// real poles; sections filled from the last, each time with the remaining
// pole nearest the unit circle (with its conjugate, or the next such real
// pole) and the two remaining zeros nearest it, so the sharpest resonances
// come last; the gain on the first section.
std::vector<std::array<double, 6>> PairSections(std::vector<Complex> poles, std::vector<Complex> zeros, double gain) {
  const auto worst = [&](bool real_only) {  // the remaining pole nearest the unit circle
    std::size_t best = poles.size();
    for (std::size_t i = 0; i < poles.size(); ++i) {
      if ((!real_only || IsReal(poles[i])) &&
          (best == poles.size() || std::abs(1.0 - std::abs(poles[i])) < std::abs(1.0 - std::abs(poles[best])))) {
        best = i;
      }
    }
    return best;
  };
  std::vector<std::array<double, 6>> sos(zeros.size() / 2);  // zeros: every one, poles: one of each pair
  for (std::size_t s = sos.size(); s-- > 0;) {
    const Complex p1 = TakeAt(poles, worst(false));
    const Complex p2 = IsReal(p1) ? TakeAt(poles, worst(true)) : std::conj(p1);
    const Complex z1 = TakeAt(zeros, Nearest(zeros, p1, [](Complex) { return true; }));
    const Complex z2 = TakeAt(zeros, Nearest(zeros, p1, IsReal));
    const auto b = Quadratic(z1, z2), a = Quadratic(p1, p2);
    sos[s] = {b[0], b[1], b[2], a[0], a[1], a[2]};
  }
  for (std::size_t k = 0; k < 3; ++k) sos[0][k] *= gain;
  return sos;
}

// lfilter_zi of one section, (I - A^T) zi = b[1:] - a[1:] b[0], solved in
// closed form: zi0 (1 + a1 + a2) = B0 + B1, zi1 = B1 - a2 zi0.
std::array<double, 2> SectionSteadyState(const std::array<double, 6>& s) {
  const double r0 = s[1] - s[4] * s[0], r1 = s[2] - s[5] * s[0];
  const double zi0 = (r0 + r1) / (1.0 + s[4] + s[5]);
  return {zi0, r1 - s[5] * zi0};
}

// sosfilt in place over `count` samples `step` apart (+1 or -1), kLanes
// channels interleaved, from state zi * each channel's first sample: each
// section direct form II transposed, its output the next's input, in scipy's
// order of operations. The lanes are independent chains, so the processor
// overlaps them; the state stays in registers for the known section count.
template <std::size_t kSections>
void RunSections(const ButterworthDesign& design, double* x, Eigen::Index count, Eigen::Index step) {
  std::array<double, 6> c[kSections];
  double s0[kSections][kLanes], s1[kSections][kLanes];
  for (std::size_t s = 0; s < kSections; ++s) {
    c[s] = design.sections[s];
    for (int l = 0; l < kLanes; ++l) {
      s0[s][l] = design.zi[s][0] * x[l];
      s1[s][l] = design.zi[s][1] * x[l];
    }
  }
  for (Eigen::Index i = 0; i < count; ++i) {
    double* sample = x + i * step * kLanes;
    double value[kLanes];
    for (int l = 0; l < kLanes; ++l) value[l] = sample[l];
    for (std::size_t s = 0; s < kSections; ++s) {
      for (int l = 0; l < kLanes; ++l) {
        const double out = c[s][0] * value[l] + s0[s][l];
        s0[s][l] = c[s][1] * value[l] - c[s][4] * out + s1[s][l];
        s1[s][l] = c[s][2] * value[l] - c[s][5] * out;
        value[l] = out;
      }
    }
    for (int l = 0; l < kLanes; ++l) sample[l] = value[l];
  }
}

void RunSections(const ButterworthDesign& design, double* x, Eigen::Index count, Eigen::Index step) {
  switch (design.sections.size()) {
    case 1: RunSections<1>(design, x, count, step); return;
    case 2: RunSections<2>(design, x, count, step); return;
    case 3: RunSections<3>(design, x, count, step); return;
    default: RunSections<4>(design, x, count, step); return;  // order 8 at most (Validate)
  }
}

}  // namespace

ButterworthDesign DesignButterworth(int order, double cutoff, double fps) {
  double gain = 1.0;
  std::vector<Complex> poles = ButterworthPoles(order, cutoff, fps, gain);
  std::vector<Complex> zeros(static_cast<std::size_t>(order), Complex(-1.0, 0.0));
  if (order % 2 == 1) {  // 'nearest' pairs an odd order with a pole and a zero at the origin
    poles.emplace_back(0.0, 0.0);
    zeros.emplace_back(0.0, 0.0);
  }
  // _cplxreal: one of each conjugate pair, averaged, then the real poles.
  std::vector<Complex> halves;
  for (const Complex& p : poles) {
    if (p.imag() > 0.0) halves.push_back(p);
  }
  for (const Complex& p : poles) {
    if (p.imag() == 0.0) halves.push_back(p);
  }
  ButterworthDesign design;
  design.sections = PairSections(halves, zeros, gain);
  // sosfilt_zi: each section's steady state, scaled by the DC gain of those before it.
  double scale = 1.0;
  for (const auto& s : design.sections) {
    const auto zi = SectionSteadyState(s);
    design.zi.push_back({scale * zi[0], scale * zi[1]});
    scale *= (s[0] + s[1] + s[2]) / (s[3] + s[4] + s[5]);
  }
  // sosfiltfilt's padding: 3 (2 sections + 1) taps, less one where a section is of first order.
  int b2_zero = 0, a2_zero = 0;
  for (const auto& s : design.sections) {
    b2_zero += s[2] == 0.0;
    a2_zero += s[5] == 0.0;
  }
  design.taps = 2 * static_cast<int>(design.sections.size()) + 1 - std::min(b2_zero, a2_zero);
  return design;
}

Eigen::Index ButterworthPadding(const ButterworthDesign& design, Eigen::Index n) {
  return std::min<Eigen::Index>(3 * design.taps, n - 1);
}

void ButterworthFilter(const ButterworthDesign& design, const double* x, Eigen::Index x_stride, int lanes,
                       Eigen::Index n, double* out, Eigen::Index out_stride, double* scratch) {
  // sosfiltfilt: extend each end by its point reflection (2 x[0] - x[j]),
  // filter forwards from the steady state of the first extended sample, then
  // backwards from that of the last output, and drop the extensions. Lanes
  // beyond `lanes` repeat the last one and are not written.
  const Eigen::Index pad = ButterworthPadding(design, n), length = n + 2 * pad;
  double* extended = scratch;
  int lane[kLanes];
  for (int l = 0; l < kLanes; ++l) lane[l] = std::min(l, lanes - 1);
  // A sample's lanes together, in one sweep of the input (not one a lane).
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int l = 0; l < kLanes; ++l) extended[(pad + i) * kLanes + l] = x[i * x_stride + lane[l]];
  }
  for (int l = 0; l < kLanes; ++l) {
    const double* in = x + lane[l];
    const auto at = [&](Eigen::Index i) { return in[i * x_stride]; };
    for (Eigen::Index j = 1; j <= pad; ++j) {
      extended[(pad - j) * kLanes + l] = 2.0 * at(0) - at(j);
      extended[(pad + n - 1 + j) * kLanes + l] = 2.0 * at(n - 1) - at(n - 1 - j);
    }
  }
  RunSections(design, extended, length, 1);
  RunSections(design, extended + (length - 1) * kLanes, length, -1);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int l = 0; l < lanes; ++l) out[i * out_stride + l] = extended[(pad + i) * kLanes + l];
  }
}

}  // namespace motionkit::internal
