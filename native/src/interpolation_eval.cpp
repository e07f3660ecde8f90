// Sampling: per-segment power-basis cubics evaluated with Horner's rule, and
// the barycentric form of the polynomial through all keys.
#include <algorithm>
#include <cmath>

#include "interpolation_internal.hpp"

namespace motionkit::interpolation_detail {
namespace {

// First index in [lo, m) whose time is >= bound (or > bound when `after`),
// galloping from lo: sorted samples usually move on by a few per segment.
template <bool kAfter>
Index SearchFrom(const double* x, Index lo, Index m, double bound) {
  auto before = [bound](double v) { return kAfter ? v <= bound : v < bound; };
  if (lo >= m || !before(x[lo])) return lo;
  Index known = lo;  // x[known] is before the bound
  Index step = 1;
  while (known + step < m && before(x[known + step])) {
    known += step;
    step *= 2;
  }
  Index first = known + 1, last = std::min(known + step, m);
  while (first < last) {
    const Index mid = first + (last - first) / 2;
    if (before(x[mid])) first = mid + 1; else last = mid;
  }
  return first;
}

inline double Horner(const double* c, double u) { return c[0] + u * (c[1] + u * (c[2] + u * c[3])); }
inline double HornerSlope(const double* c, double u) {
  return c[1] + u * (2.0 * c[2] + u * (3.0 * c[3]));
}

// Where EvaluateCubic writes: sample s's component j at out[s * os() + j] (and its derivative in dout, when
// asked), from the segments' power-basis coefficients. The scalar case's sizes and strides are constants,
// so that the compiler vectorises its loops over samples.
template <bool kScalar>
struct CubicSamples {
  const CurveKeys& keys;
  const double* coeffs;
  double* out;
  Index out_stride;
  double* dout;  // null: no derivatives
  Index dout_stride;

  Index components() const { return kScalar ? 1 : keys.d; }
  Index os() const { return kScalar ? 1 : out_stride; }
  Index ds() const { return kScalar ? 1 : dout_stride; }
  const double* Segment(Index k, Index j) const { return coeffs + (k * components() + j) * 4; }

  // Outside the keys (and everywhere for one key): hold the end value, flat.
  void Hold(Index s, Index key) const {
    for (Index j = 0; j < components(); ++j) {
      out[s * os() + j] = keys.y_at(key, j);
      if (dout) dout[s * ds() + j] = 0.0;
    }
  }

  // On the last key: its value exactly, the last segment's slope.
  void OnLast(Index s) const {
    const Index n = keys.n;
    for (Index j = 0; j < components(); ++j) {
      out[s * os() + j] = keys.y_at(n - 1, j);
      if (dout) dout[s * ds() + j] = HornerSlope(Segment(n - 2, j), keys.t[n - 1] - keys.t[n - 2]);
    }
  }

  void InSegment(Index s, Index k, double u) const {
    for (Index j = 0; j < components(); ++j) {
      const double* c = Segment(k, j);
      out[s * os() + j] = Horner(c, u);
      if (dout) dout[s * ds() + j] = HornerSlope(c, u);
    }
  }

  // Samples in any order, each segment found by search unless it is the previous sample's (neighbours
  // often share one).
  void EvaluateAnyOrder(const double* x, Index m) const {
    const Index n = keys.n;
    const double first = keys.t[0], last = keys.t[n - 1];
    Index k = 0;
    for (Index s = 0; s < m; ++s) {
      const double time = x[s];
      if (time < first) {
        Hold(s, 0);
      } else if (time > last) {
        Hold(s, n - 1);
      } else if (time == last) {
        OnLast(s);
      } else {
        if (!(keys.t[k] <= time && time < keys.t[k + 1])) {
          k = static_cast<Index>(std::upper_bound(keys.t, keys.t + n, time) - keys.t) - 1;
        }
        InSegment(s, k, time - keys.t[k]);
      }
    }
  }

  // Sorted samples: a segment's run of samples at a time.
  void EvaluateSorted(const double* x, Index m) const {
    const Index n = keys.n;
    Index s = SearchFrom<false>(x, 0, m, keys.t[0]);
    for (Index b = 0; b < s; ++b) Hold(b, 0);
    for (Index k = 0; k + 1 < n && s < m; ++k) {
      const Index end = SearchFrom<false>(x, s, m, keys.t[k + 1]);
      RunInSegment(x, k, s, end);
      s = end;
    }
    const Index past = SearchFrom<true>(x, s, m, keys.t[n - 1]);
    for (; s < past; ++s) OnLast(s);
    for (; s < m; ++s) Hold(s, n - 1);
  }

  // Samples [s, end) in segment k. Plain loops over contiguous samples with fixed coefficients: the
  // compiler vectorises the scalar case.
  void RunInSegment(const double* x, Index k, Index s, Index end) const {
    const double tk = keys.t[k];
    for (Index j = 0; j < components(); ++j) {
      const double* c = Segment(k, j);
      const double c0 = c[0], c1 = c[1], c2 = c[2], c3 = c[3];
      for (Index i = s; i < end; ++i) {
        const double u = x[i] - tk;
        out[i * os() + j] = c0 + u * (c1 + u * (c2 + u * c3));
      }
      if (dout) {
        const double e1 = 2.0 * c2, e2 = 3.0 * c3;
        for (Index i = s; i < end; ++i) {
          const double u = x[i] - tk;
          dout[i * ds() + j] = c1 + u * (e1 + u * e2);
        }
      }
    }
  }
};

}  // namespace

bool IsSorted(const double* x, Index m) {
  for (Index s = 1; s < m; ++s) {
    if (x[s] < x[s - 1]) return false;
  }
  return true;
}

void HermiteCoefficients(const CurveKeys& keys, const double* slopes_in, const double* slopes_out,
                         double* coeffs) {
  const Index d = keys.d;
  for (Index k = 0; k + 1 < keys.n; ++k) {
    const double h = keys.t[k + 1] - keys.t[k];
    for (Index j = 0; j < d; ++j) {
      // scipy's CubicHermiteSpline, term for term.
      const double m0 = slopes_out[k * d + j], m1 = slopes_in[(k + 1) * d + j];
      const double y0 = keys.y_at(k, j);
      const double slope = (keys.y_at(k + 1, j) - y0) / h;
      const double t = (m0 + m1 - 2.0 * slope) / h;
      double* c = coeffs + (k * d + j) * 4;
      c[0] = y0;
      c[1] = m0;
      c[2] = (slope - m0) / h - t;
      c[3] = t / h;
    }
  }
}

void SteppedCoefficients(const CurveKeys& keys, double* coeffs) {
  const Index d = keys.d;
  for (Index k = 0; k + 1 < keys.n; ++k) {
    for (Index j = 0; j < d; ++j) {
      double* c = coeffs + (k * d + j) * 4;
      c[0] = keys.y_at(k, j);
      c[1] = c[2] = c[3] = 0.0;
    }
  }
}

template <bool kScalar>
void EvaluateCubic(const CurveKeys& keys, const double* coeffs, const double* x, Index m,
                   bool sorted, double* out, Index out_stride, double* dout, Index dout_stride) {
  const CubicSamples<kScalar> samples{keys, coeffs, out, out_stride, dout, dout_stride};
  if (keys.n == 1) {
    for (Index s = 0; s < m; ++s) samples.Hold(s, 0);
  } else if (sorted) {
    samples.EvaluateSorted(x, m);
  } else {
    samples.EvaluateAnyOrder(x, m);
  }
}

template void EvaluateCubic<true>(const CurveKeys&, const double*, const double*, Index, bool,
                                  double*, Index, double*, Index);
template void EvaluateCubic<false>(const CurveKeys&, const double*, const double*, Index, bool,
                                   double*, Index, double*, Index);

void BarycentricWeights(const CurveKeys& keys, double* weights) {
  const Index n = keys.n;
  if (n == 1) {
    weights[0] = 1.0;
    return;
  }
  // Scaled by 4 / (span of the times), as scipy's BarycentricInterpolator:
  // the scale cancels in the formula and keeps the products representable.
  const double scale = 4.0 / (keys.t[n - 1] - keys.t[0]);
  for (Index i = 0; i < n; ++i) {
    double product = 1.0;
    for (Index k = 0; k < n; ++k) {
      if (k != i) product *= scale * (keys.t[i] - keys.t[k]);
    }
    weights[i] = 1.0 / product;
  }
}

void EvaluatePolynomial(const CurveKeys& keys, const double* w, const double* x, Index m,
                        double* out, Index out_stride, double* dout, Index dout_stride) {
  const Index n = keys.n, d = keys.d;
  const double* t = keys.t;
  for (Index s = 0; s < m; ++s) {
    const double time = x[s];
    double* value = out + s * out_stride;
    double* slope = dout ? dout + s * dout_stride : nullptr;
    if (n == 1 || time < t[0] || time > t[n - 1]) {  // hold the end value, flat
      const Index key = n == 1 || time < t[0] ? 0 : n - 1;
      for (Index j = 0; j < d; ++j) {
        value[j] = keys.y_at(key, j);
        if (slope) slope[j] = 0.0;
      }
      continue;
    }
    Index node = -1;
    for (Index i = 0; i < n; ++i) {
      if (time == t[i]) {
        node = i;
        break;
      }
    }
    for (Index j = 0; j < d; ++j) {
      if (node >= 0) {
        // p(t_i) = y_i; p'(t_i) = sum over k != i of (w_k / w_i)(y_k - y_i)/(t_i - t_k)
        // (Berrut & Trefethen 2004, eq. 9.4).
        const double yi = keys.y_at(node, j);
        value[j] = yi;
        if (slope) {
          double sum = 0.0;
          for (Index k = 0; k < n; ++k) {
            if (k != node) sum += w[k] * (keys.y_at(k, j) - yi) / (t[node] - t[k]);
          }
          slope[j] = sum / w[node];
        }
        continue;
      }
      double numerator = 0.0, denominator = 0.0;
      for (Index k = 0; k < n; ++k) {
        const double q = w[k] / (time - t[k]);
        numerator += q * keys.y_at(k, j);
        denominator += q;
      }
      const double p = numerator / denominator;
      value[j] = p;
      if (slope) {
        // p' = sum_k w_k (p - y_k) / (t - t_k)^2 / sum_k w_k / (t - t_k).
        double sum = 0.0;
        for (Index k = 0; k < n; ++k) {
          const double u = time - t[k];
          sum += w[k] * (p - keys.y_at(k, j)) / (u * u);
        }
        slope[j] = sum / denominator;
      }
    }
  }
}

}  // namespace motionkit::interpolation_detail
