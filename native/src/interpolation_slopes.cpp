// The slope rules that turn keys into a piecewise cubic Hermite, one per
// interpolant. The spline and PCHIP rules follow scipy's CubicSpline and
// PchipInterpolator expression for expression, so that results agree to
// rounding.
#include <algorithm>
#include <cmath>

#include "interpolation_internal.hpp"

namespace motionkit::interpolation_detail {
namespace {

// Same slope on both sides of every key.
void CopySymmetric(Index count, const double* slopes, double* slopes_in, double* slopes_out) {
  std::copy(slopes, slopes + count, slopes_in);
  if (slopes_out != slopes) std::copy(slopes, slopes + count, slopes_out);
}

void SecantSlopes(const CurveKeys& k, double* slopes_in, double* slopes_out) {
  const Index n = k.n, d = k.d;
  for (Index i = 0; i + 1 < n; ++i) {
    const double h = k.t[i + 1] - k.t[i];
    for (Index j = 0; j < d; ++j) {
      const double secant = (k.y_at(i + 1, j) - k.y_at(i, j)) / h;
      slopes_out[i * d + j] = secant;
      slopes_in[(i + 1) * d + j] = secant;
    }
  }
  for (Index j = 0; j < d; ++j) {
    slopes_in[j] = slopes_out[j];
    slopes_out[(n - 1) * d + j] = slopes_in[(n - 1) * d + j];
  }
}

// Tridiagonal system for one spline: sub[i] s_{i-1} + diag[i] s_i + sup[i] s_{i+1},
// factored once (the matrix depends on the times only) and solved per component.
// No pivoting: every system here is diagonally dominant but for the not-a-knot
// end rows, whose eliminated pivots stay positive (x[2] - x[0] > dx[1] is
// absorbed by the next row's 2 (dx[0] + dx[1])).
struct Tridiagonal {
  double* sub;
  double* diag;
  double* sup;
  double* pivot;  // factored diagonal
  double* ratio;  // sup / pivot
  Index size;

  void Factor() {
    pivot[0] = diag[0];
    for (Index i = 0; i < size; ++i) {
      if (i > 0) pivot[i] = diag[i] - sub[i] * ratio[i - 1];
      ratio[i] = i + 1 < size ? sup[i] / pivot[i] : 0.0;
    }
  }
  // Solves in place: rhs becomes the solution.
  void Solve(double* rhs) const {
    rhs[0] /= pivot[0];
    for (Index i = 1; i < size; ++i) rhs[i] = (rhs[i] - sub[i] * rhs[i - 1]) / pivot[i];
    for (Index i = size - 2; i >= 0; --i) rhs[i] -= ratio[i] * rhs[i + 1];
  }
};

// dx[i] = t[i+1] - t[i]; slope[i] the component's secants.
void Secants(const CurveKeys& k, Index j, const double* dx, double* slope) {
  for (Index i = 0; i + 1 < k.n; ++i) slope[i] = (k.y_at(i + 1, j) - k.y_at(i, j)) / dx[i];
}

// Not-a-knot on two or three keys, which scipy answers in closed form: on two, the secant slope at both
// ends; on three both conditions coincide and scipy takes the parabola through the keys, whose slopes
// these are. False for more keys.
bool ShortNotAKnotSlopes(const CurveKeys& k, const double* dx, double* slope, double* s) {
  const Index n = k.n, d = k.d;
  if (n == 2) {
    for (Index j = 0; j < d; ++j) s[j] = s[d + j] = (k.y_at(1, j) - k.y_at(0, j)) / dx[0];
    return true;
  }
  if (n != 3) return false;
  for (Index j = 0; j < d; ++j) {
    Secants(k, j, dx, slope);
    const double mid = (dx[1] * slope[0] + dx[0] * slope[1]) / (dx[0] + dx[1]);
    s[j] = 2.0 * slope[0] - mid;
    s[d + j] = mid;
    s[2 * d + j] = 2.0 * slope[1] - mid;
  }
  return true;
}

// The open splines' matrix: continuity of the second derivative inside, `kind`'s condition at the ends.
void OpenSplineMatrix(Interpolant kind, const CurveKeys& k, const double* dx, Tridiagonal* tri) {
  const Index n = k.n, last = n - 1;
  for (Index i = 1; i + 1 < n; ++i) {
    tri->sub[i] = dx[i];
    tri->diag[i] = 2.0 * (dx[i - 1] + dx[i]);
    tri->sup[i] = dx[i - 1];
  }
  tri->sub[0] = 0.0;
  tri->sup[last] = 0.0;
  switch (kind) {
    case Interpolant::kNotAKnotSpline:
      tri->diag[0] = dx[1];
      tri->sup[0] = k.t[2] - k.t[0];
      tri->diag[last] = dx[last - 2];
      tri->sub[last] = k.t[last] - k.t[last - 2];
      break;
    case Interpolant::kClampedSpline:
      tri->diag[0] = 1.0;
      tri->sup[0] = 0.0;
      tri->diag[last] = 1.0;
      tri->sub[last] = 0.0;
      break;
    default:  // natural
      tri->diag[0] = 2.0 * dx[0];
      tri->sup[0] = dx[0];
      tri->diag[last] = 2.0 * dx[last - 1];
      tri->sub[last] = dx[last - 1];
      break;
  }
}

// The right-hand side for component j, whose secants `slope` holds.
void OpenSplineRhs(Interpolant kind, const CurveKeys& k, const CurveExtras& extras, Index j, const double* dx,
                   const double* slope, double* rhs) {
  const Index n = k.n, last = n - 1;
  for (Index i = 1; i + 1 < n; ++i) rhs[i] = 3.0 * (dx[i] * slope[i - 1] + dx[i - 1] * slope[i]);
  switch (kind) {
    case Interpolant::kNotAKnotSpline: {
      const double a = k.t[2] - k.t[0];
      rhs[0] = ((dx[0] + 2.0 * a) * dx[1] * slope[0] + dx[0] * dx[0] * slope[1]) / a;
      const double b = k.t[last] - k.t[last - 2];
      rhs[last] = (dx[last - 1] * dx[last - 1] * slope[last - 2] +
                   (2.0 * b + dx[last - 1]) * dx[last - 2] * slope[last - 1]) /
                  b;
      break;
    }
    case Interpolant::kClampedSpline:
      rhs[0] = extras.start_slope ? extras.start_slope[j] : 0.0;
      rhs[last] = extras.end_slope ? extras.end_slope[j] : 0.0;
      break;
    default:
      rhs[0] = 3.0 * (k.y_at(1, j) - k.y_at(0, j));
      rhs[last] = 3.0 * (k.y_at(last, j) - k.y_at(last - 1, j));
      break;
  }
}

// Natural, clamped and not-a-knot: n x n tridiagonal (scipy's banded system).
void OpenSplineSlopes(Interpolant kind, const CurveKeys& k, const CurveExtras& extras, double* s,
                      double* work) {
  const Index n = k.n, d = k.d;
  double* dx = work;
  double* slope = dx + n;
  double* rhs = slope + n;
  Tridiagonal tri{rhs + n, rhs + 2 * n, rhs + 3 * n, rhs + 4 * n, rhs + 5 * n, n};
  for (Index i = 0; i + 1 < n; ++i) dx[i] = k.t[i + 1] - k.t[i];
  if (kind == Interpolant::kNotAKnotSpline && ShortNotAKnotSlopes(k, dx, slope, s)) return;
  OpenSplineMatrix(kind, k, dx, &tri);
  tri.Factor();
  for (Index j = 0; j < d; ++j) {
    Secants(k, j, dx, slope);
    OpenSplineRhs(kind, k, extras, j, dx, slope, rhs);
    tri.Solve(rhs);
    for (Index i = 0; i < n; ++i) s[i * d + j] = rhs[i];
  }
}

// Periodic: n - 1 unknowns (s_{n-1} = s_0) in a cyclic tridiagonal system,
// solved with Sherman-Morrison around a tridiagonal one.
void PeriodicSplineSlopes(const CurveKeys& k, double* s, double* work) {
  const Index n = k.n, d = k.d, p = n - 1;
  double* dx = work;
  double* slope = dx + n;
  double* rhs = slope + n;
  double* z = rhs + n;
  Tridiagonal tri{z + n, z + 2 * n, z + 3 * n, z + 4 * n, z + 5 * n, p};
  for (Index i = 0; i < p; ++i) dx[i] = k.t[i + 1] - k.t[i];

  if (p == 1) {  // two equal keys: a constant
    for (Index j = 0; j < 2 * d; ++j) s[j] = 0.0;
    return;
  }
  if (p == 2) {
    // Both neighbours of each unknown are the other one; the two equations
    // coincide and give the same slope at every key.
    for (Index j = 0; j < d; ++j) {
      Secants(k, j, dx, slope);
      const double v = (dx[1] * slope[0] + dx[0] * slope[1]) / (dx[0] + dx[1]);
      s[j] = s[d + j] = s[2 * d + j] = v;
    }
    return;
  }
  // Row i: dx[i] s_{i-1} + 2 (dx[i-1] + dx[i]) s_i + dx[i-1] s_{i+1}, indices mod p.
  for (Index i = 0; i < p; ++i) {
    const double before = dx[(i + p - 1) % p], after = dx[i];
    tri.sub[i] = after;
    tri.diag[i] = 2.0 * (before + after);
    tri.sup[i] = before;
  }
  const double top_right = tri.sub[0];     // row 0, column p - 1
  const double bottom_left = tri.sup[p - 1];  // row p - 1, column 0
  const double gamma = -tri.diag[0];
  tri.sub[0] = 0.0;
  tri.sup[p - 1] = 0.0;
  tri.diag[0] -= gamma;
  tri.diag[p - 1] -= bottom_left * top_right / gamma;
  tri.Factor();
  std::fill(z, z + p, 0.0);
  z[0] = gamma;
  z[p - 1] = bottom_left;
  tri.Solve(z);
  const double z_dot = 1.0 + z[0] + top_right * z[p - 1] / gamma;

  for (Index j = 0; j < d; ++j) {
    Secants(k, j, dx, slope);
    for (Index i = 0; i < p; ++i) {
      const Index prev = (i + p - 1) % p;
      rhs[i] = 3.0 * (dx[i] * slope[prev] + dx[prev] * slope[i]);
    }
    tri.Solve(rhs);
    const double factor = (rhs[0] + top_right * rhs[p - 1] / gamma) / z_dot;
    for (Index i = 0; i < p; ++i) s[i * d + j] = rhs[i] - factor * z[i];
    s[p * d + j] = s[j];
  }
}

double Sign(double v) { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); }

// scipy's PchipInterpolator._edge_case (Moler's pchiptx end rule).
double PchipEnd(double h0, double h1, double m0, double m1) {
  const double d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1);
  if (Sign(d) != Sign(m0)) return 0.0;
  if (Sign(m0) != Sign(m1) && std::abs(d) > 3.0 * std::abs(m0)) return 3.0 * m0;
  return d;
}

void MonotoneSlopes(const CurveKeys& k, double* s, double* work) {
  const Index n = k.n, d = k.d;
  double* h = work;
  double* m = h + n;
  for (Index i = 0; i + 1 < n; ++i) h[i] = k.t[i + 1] - k.t[i];
  for (Index j = 0; j < d; ++j) {
    Secants(k, j, h, m);
    if (n == 2) {
      s[j] = s[d + j] = m[0];
      continue;
    }
    for (Index i = 1; i + 1 < n; ++i) {
      const double before = m[i - 1], after = m[i];
      if (Sign(after) != Sign(before) || after == 0.0 || before == 0.0) {
        s[i * d + j] = 0.0;
        continue;
      }
      // Weighted harmonic mean of the neighbouring secants (Fritsch-Butland).
      const double w1 = 2.0 * h[i] + h[i - 1];
      const double w2 = h[i] + 2.0 * h[i - 1];
      s[i * d + j] = 1.0 / ((w1 / before + w2 / after) / (w1 + w2));
    }
    s[j] = PchipEnd(h[0], h[1], m[0], m[1]);
    s[(n - 1) * d + j] = PchipEnd(h[n - 2], h[n - 3], m[n - 2], m[n - 3]);
  }
}

void CatmullRomSlopes(const CurveKeys& k, double* s) {
  const Index n = k.n, d = k.d;
  for (Index j = 0; j < d; ++j) {
    s[j] = (k.y_at(1, j) - k.y_at(0, j)) / (k.t[1] - k.t[0]);
    s[(n - 1) * d + j] = (k.y_at(n - 1, j) - k.y_at(n - 2, j)) / (k.t[n - 1] - k.t[n - 2]);
  }
  for (Index i = 1; i + 1 < n; ++i) {
    const double span = k.t[i + 1] - k.t[i - 1];
    for (Index j = 0; j < d; ++j) s[i * d + j] = (k.y_at(i + 1, j) - k.y_at(i - 1, j)) / span;
  }
}

// Written as Catmull-Rom's numerator plus corrections that vanish exactly at
// T = C = B = 0, so that case reproduces kCatmullRom bit for bit.
void KochanekBartelsSlopes(const CurveKeys& k, const CurveExtras& e, double* slopes_in,
                           double* slopes_out) {
  const Index n = k.n, d = k.d;
  for (Index i = 0; i < n; ++i) {
    const double tension = e.tension ? e.tension[i] : 0.0;
    const double continuity = e.continuity ? e.continuity[i] : 0.0;
    const double bias = e.bias ? e.bias[i] : 0.0;
    const double a_in = (1.0 - tension) * (1.0 - continuity) * (1.0 + bias) - 1.0;
    const double b_in = (1.0 - tension) * (1.0 + continuity) * (1.0 - bias) - 1.0;
    const double a_out = (1.0 - tension) * (1.0 + continuity) * (1.0 + bias) - 1.0;
    const double b_out = (1.0 - tension) * (1.0 - continuity) * (1.0 - bias) - 1.0;
    // A missing neighbour is the mirror image of the present one.
    const Index lo = i == 0 ? 0 : i - 1;
    const Index hi = i + 1 == n ? n - 1 : i + 1;
    const double span = i == 0 || i + 1 == n ? 2.0 * (k.t[hi] - k.t[lo]) : k.t[hi] - k.t[lo];
    for (Index j = 0; j < d; ++j) {
      double before, after, across;
      if (i == 0) {
        before = after = k.y_at(1, j) - k.y_at(0, j);
        across = 2.0 * after;
      } else if (i + 1 == n) {
        before = after = k.y_at(i, j) - k.y_at(i - 1, j);
        across = 2.0 * before;
      } else {
        before = k.y_at(i, j) - k.y_at(i - 1, j);
        after = k.y_at(i + 1, j) - k.y_at(i, j);
        across = k.y_at(i + 1, j) - k.y_at(i - 1, j);
      }
      slopes_in[i * d + j] = (across + a_in * before + b_in * after) / span;
      slopes_out[i * d + j] = (across + a_out * before + b_out * after) / span;
    }
  }
  // The outward slopes continue the end segments (HermiteFormJob's contract).
  for (Index j = 0; j < d; ++j) {
    slopes_in[j] = slopes_out[j];
    slopes_out[(n - 1) * d + j] = slopes_in[(n - 1) * d + j];
  }
}

// Barry-Goldman Catmull-Rom over chord-length knots, re-timed per segment.
void BarryGoldmanSlopes(const CurveKeys& k, double alpha, double* slopes_in, double* slopes_out,
                        double* work) {
  const Index n = k.n, d = k.d;
  double* ds = work;  // knot spacing per segment, 0 for coincident keys
  for (Index i = 0; i + 1 < n; ++i) {
    double squared = 0.0;
    for (Index j = 0; j < d; ++j) {
      const double step = k.y_at(i + 1, j) - k.y_at(i, j);
      squared += step * step;
    }
    ds[i] = alpha == 0.5 ? std::sqrt(std::sqrt(squared)) : std::sqrt(squared);
  }
  // Chord velocity of segment c in s, component j; 0 for a coincident segment.
  auto velocity = [&](Index c, Index j) {
    return ds[c] > 0.0 ? (k.y_at(c + 1, j) - k.y_at(c, j)) / ds[c] : 0.0;
  };
  for (Index i = 0; i < n; ++i) {
    const double before = i > 0 ? ds[i - 1] : 0.0;
    const double after = i + 1 < n ? ds[i] : 0.0;
    // Rates that turn d/ds into d/dt on the segment before and after.
    const double rate_in = i > 0 ? before / (k.t[i] - k.t[i - 1]) : 0.0;
    const double rate_out = i + 1 < n ? after / (k.t[i + 1] - k.t[i]) : 0.0;
    for (Index j = 0; j < d; ++j) {
      double tangent;  // dP/ds at key i
      if (before > 0.0 && after > 0.0) {
        tangent = (after * velocity(i - 1, j) + before * velocity(i, j)) / (before + after);
      } else if (after > 0.0) {
        tangent = velocity(i, j);
      } else if (before > 0.0) {
        tangent = velocity(i - 1, j);
      } else {
        tangent = 0.0;
      }
      slopes_in[i * d + j] = tangent * rate_in;
      slopes_out[i * d + j] = tangent * rate_out;
    }
  }
  for (Index j = 0; j < d; ++j) {
    slopes_in[j] = slopes_out[j];
    slopes_out[(n - 1) * d + j] = slopes_in[(n - 1) * d + j];
  }
}

}  // namespace

void HermiteSlopes(Interpolant kind, const CurveKeys& keys, const CurveExtras& extras,
                   double* slopes_in, double* slopes_out, double* work) {
  const Index count = keys.n * keys.d;
  if (keys.n == 1) {  // a constant
    std::fill(slopes_in, slopes_in + count, 0.0);
    std::fill(slopes_out, slopes_out + count, 0.0);
    return;
  }
  switch (kind) {
    case Interpolant::kLinear:
      SecantSlopes(keys, slopes_in, slopes_out);
      return;
    case Interpolant::kNaturalSpline:
    case Interpolant::kClampedSpline:
    case Interpolant::kNotAKnotSpline:
      OpenSplineSlopes(kind, keys, extras, slopes_out, work);
      break;
    case Interpolant::kPeriodicSpline:
      PeriodicSplineSlopes(keys, slopes_out, work);
      break;
    case Interpolant::kHermite:
      for (Index i = 0; i < keys.n; ++i) {
        for (Index j = 0; j < keys.d; ++j) {
          slopes_out[i * keys.d + j] = extras.slopes[i * extras.slopes_stride + j];
        }
      }
      break;
    case Interpolant::kCatmullRom:
      CatmullRomSlopes(keys, slopes_out);
      break;
    case Interpolant::kMonotone:
      MonotoneSlopes(keys, slopes_out, work);
      break;
    case Interpolant::kKochanekBartels:
      KochanekBartelsSlopes(keys, extras, slopes_in, slopes_out);
      return;
    case Interpolant::kCentripetalCatmullRom:
      BarryGoldmanSlopes(keys, 0.5, slopes_in, slopes_out, work);
      return;
    case Interpolant::kChordalCatmullRom:
      BarryGoldmanSlopes(keys, 1.0, slopes_in, slopes_out, work);
      return;
    case Interpolant::kStepped:
    case Interpolant::kPolynomial:
      std::fill(slopes_in, slopes_in + count, 0.0);
      std::fill(slopes_out, slopes_out + count, 0.0);
      return;
  }
  CopySymmetric(count, slopes_out, slopes_in, slopes_out);
}

}  // namespace motionkit::interpolation_detail
