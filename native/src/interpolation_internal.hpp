// Shared between the interpolation sources; not part of the public API.
// Plain pointers and strides so that one curve of d components (InterpolateJob)
// and one scalar curve cut out of the CSR arrays (InterpolateCurvesJob) go
// through the same code without copies.
#pragma once

#include <vector>

#include "motionkit/interpolation.hpp"

namespace motionkit::interpolation_detail {

using Index = Eigen::Index;

struct CurveKeys {
  const double* t = nullptr;  // n
  Index n = 0;
  const double* y = nullptr;  // y[i * y_stride + j], j < d
  Index y_stride = 0;
  Index d = 1;
  double y_at(Index i, Index j) const { return y[i * y_stride + j]; }
};

// The optional per-curve inputs; null when absent.
struct CurveExtras {
  const double* start_slope = nullptr;  // d
  const double* end_slope = nullptr;    // d
  const double* slopes = nullptr;       // slopes[i * slopes_stride + j]
  Index slopes_stride = 0;
  const double* tension = nullptr;      // n each
  const double* continuity = nullptr;
  const double* bias = nullptr;
};

// Doubles of scratch that HermiteSlopes needs for n keys.
inline Index SlopeWorkSize(Index n) { return 10 * n + 8; }

// Slopes of a Hermite-form kind (IsHermiteForm), n x d each, contiguous rows.
// Inputs are valid (checked by the jobs).
void HermiteSlopes(Interpolant kind, const CurveKeys& keys, const CurveExtras& extras,
                   double* slopes_in, double* slopes_out, double* work);

// Power-basis cubics per segment and component, 4 doubles each in Horner
// order: coeffs[((k * d) + j) * 4 + {0, 1, 2, 3}] = value, slope, c2, c3 at
// u = t - t_k. Built as scipy's CubicHermiteSpline builds its PPoly.
void HermiteCoefficients(const CurveKeys& keys, const double* slopes_in, const double* slopes_out,
                         double* coeffs);
void SteppedCoefficients(const CurveKeys& keys, double* coeffs);

// Evaluates the piecewise cubic at m times. out[s * out_stride + j]; dout may
// be null. kScalar: d == 1 and strides 1, so the sorted inner loop vectorises.
template <bool kScalar>
void EvaluateCubic(const CurveKeys& keys, const double* coeffs, const double* x, Index m,
                   bool sorted, double* out, Index out_stride, double* dout, Index dout_stride);

// Barycentric weights (n) of the polynomial through the key times.
void BarycentricWeights(const CurveKeys& keys, double* weights);
void EvaluatePolynomial(const CurveKeys& keys, const double* weights, const double* x, Index m,
                        double* out, Index out_stride, double* dout, Index dout_stride);

bool IsSorted(const double* x, Index m);

}  // namespace motionkit::interpolation_detail
