// Butterworth low-pass designed and run as scipy does (signal.butter, then
// filtfilt with odd padding), step by step, so that the two agree to rounding.
#include <cmath>
#include <complex>
#include <utility>

#include "../so3.hpp"
#include "filter_internal.hpp"

namespace motionkit::internal {
namespace {

using Complex = std::complex<double>;

// numpy.poly: the monic polynomial with these roots, highest power first, built
// by the same sequence of products. The roots come in conjugate pairs (or are
// real), so the coefficients are real.
std::vector<double> MonicPolynomial(const std::vector<Complex>& roots) {
  std::vector<Complex> c(roots.size() + 1, Complex(0.0, 0.0));
  c[0] = 1.0;
  for (std::size_t k = 0; k < roots.size(); ++k) {
    for (std::size_t i = k + 1; i > 0; --i) c[i] -= roots[k] * c[i - 1];
  }
  std::vector<double> real(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) real[i] = c[i].real();
  return real;
}

// Solves system x = right in place (row-major n x n, destroyed) by LU with
// partial pivoting in the order of operations of reference LAPACK's dgesv,
// which numpy.linalg.solve calls: multipliers by the pivot's reciprocal,
// column-oriented substitutions. The steady state of a high-order, low cut-off
// design is ill-conditioned, and this keeps it to scipy's last bits.
void SolveAsLapack(std::vector<double>& system, std::vector<double>& right) {
  const std::size_t n = right.size();
  const auto at = [&](std::size_t i, std::size_t j) -> double& { return system[i * n + j]; };
  for (std::size_t k = 0; k < n; ++k) {
    std::size_t pivot = k;
    for (std::size_t i = k + 1; i < n; ++i) {
      if (std::abs(at(i, k)) > std::abs(at(pivot, k))) pivot = i;
    }
    for (std::size_t j = 0; j < n; ++j) std::swap(at(k, j), at(pivot, j));
    std::swap(right[k], right[pivot]);
    const double reciprocal = 1.0 / at(k, k);
    for (std::size_t i = k + 1; i < n; ++i) at(i, k) *= reciprocal;
    for (std::size_t j = k + 1; j < n; ++j) {
      for (std::size_t i = k + 1; i < n; ++i) at(i, j) -= at(k, j) * at(i, k);
    }
  }
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t i = k + 1; i < n; ++i) right[i] -= right[k] * at(i, k);
  }
  for (std::size_t k = n; k-- > 0;) {
    right[k] /= at(k, k);
    for (std::size_t i = 0; i < k; ++i) right[i] -= right[k] * at(i, k);
  }
}

// scipy.signal.lfilter_zi: the state for which a constant input gives a
// constant output from the first sample, (I - A^T) zi = b[1:] - a[1:] b[0].
std::vector<double> SteadyState(const std::vector<double>& b, const std::vector<double>& a) {
  const std::size_t n = a.size() - 1;
  std::vector<double> system(n * n, 0.0), zi(n);
  for (std::size_t i = 0; i < n; ++i) {
    system[i * n + i] = 1.0;
    system[i * n] += a[i + 1];
    if (i + 1 < n) system[i * n + i + 1] = -1.0;
    zi[i] = b[i + 1] - a[i + 1] * b[0];
  }
  SolveAsLapack(system, zi);
  return zi;
}

// scipy.signal.lfilter (direct form II transposed) in place over `count`
// samples `step` apart, from state zi * first sample.
void RunDirectForm(const ButterworthDesign& design, double* x, Eigen::Index count, Eigen::Index step,
                   double* state) {
  const std::size_t n = design.a.size() - 1;
  const double* b = design.b.data();
  const double* a = design.a.data();
  for (std::size_t k = 0; k < n; ++k) state[k] = design.zi[k] * x[0];
  for (Eigen::Index i = 0; i < count; ++i) {
    const double in = x[i * step], out = state[0] + b[0] * in;
    for (std::size_t k = 0; k + 1 < n; ++k) state[k] = state[k + 1] + in * b[k + 1] - out * a[k + 1];
    state[n - 1] = in * b[n] - out * a[n];
    x[i * step] = out;
  }
}

// Complex division as numpy does it (Smith's method), not as the C++ library
// does: the high-order designs' coefficients are sensitive enough to the last
// bit that scipy's filtfilt is matched to 1e-9 only with numpy's poles.
Complex Divide(Complex numerator, Complex denominator) {
  const double nr = numerator.real(), ni = numerator.imag(), dr = denominator.real(), di = denominator.imag();
  if (std::abs(dr) >= std::abs(di)) {
    const double ratio = di / dr, scale = 1.0 / (dr + di * ratio);
    return {(nr + ni * ratio) * scale, (ni - nr * ratio) * scale};
  }
  const double ratio = dr / di, scale = 1.0 / (di + dr * ratio);
  return {(nr * ratio + ni) * scale, (ni * ratio - nr) * scale};
}

}  // namespace

ButterworthDesign DesignButterworth(int order, double cutoff, double fps) {
  // buttap's poles, -exp(i pi m / 2N) for m = -N+1, -N+3, ..., N-1; lp2lp_zpk
  // moves them to the prewarped cut-off (scipy normalises to fs = 2, so the
  // bilinear transform's 2 fs is 4); bilinear_zpk maps them to the z-plane, with
  // N zeros at -1.
  const double normalised = 2.0 * cutoff / fps;
  const double warped = 4.0 * std::tan(kPi * normalised / 2.0);
  std::vector<Complex> poles(static_cast<std::size_t>(order)), zeros(static_cast<std::size_t>(order), -1.0);
  Complex gain_denominator(1.0, 0.0);
  for (int i = 0; i < order; ++i) {
    const double m = -order + 1 + 2 * i;
    const Complex analog = -std::exp(Divide(Complex(0.0, kPi * m), 2.0 * order)) * warped;
    gain_denominator *= 4.0 - analog;
    poles[static_cast<std::size_t>(i)] = Divide(4.0 + analog, 4.0 - analog);
  }
  const double gain = std::pow(warped, order) * Divide(1.0, gain_denominator).real();
  ButterworthDesign design;
  design.b = MonicPolynomial(zeros);
  for (double& coefficient : design.b) coefficient *= gain;
  design.a = MonicPolynomial(poles);
  design.zi = SteadyState(design.b, design.a);
  return design;
}

Eigen::Index ButterworthPadding(const ButterworthDesign& design, Eigen::Index n) {
  return std::min<Eigen::Index>(3 * static_cast<Eigen::Index>(design.a.size()), n - 1);
}

void ButterworthFilter(const ButterworthDesign& design, const double* x, Eigen::Index n, double* out,
                       double* scratch) {
  // filtfilt: extend each end by its point reflection (2 x[0] - x[j]), filter
  // forwards from the steady state of the first extended sample, then
  // backwards from that of the last output, and drop the extensions.
  const Eigen::Index pad = ButterworthPadding(design, n), length = n + 2 * pad;
  double* extended = scratch;
  std::copy(x, x + n, extended + pad);
  for (Eigen::Index j = 1; j <= pad; ++j) {
    extended[pad - j] = 2.0 * x[0] - x[j];
    extended[pad + n - 1 + j] = 2.0 * x[n - 1] - x[n - 1 - j];
  }
  double* state = extended + length;
  RunDirectForm(design, extended, length, 1, state);
  RunDirectForm(design, extended + length - 1, length, -1, state);
  std::copy(extended + pad, extended + pad + n, out);
}

}  // namespace motionkit::internal
