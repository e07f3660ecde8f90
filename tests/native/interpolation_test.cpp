#include "motionkit/interpolation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace motionkit {
namespace {

const Interpolant kAll[] = {
    Interpolant::kStepped,         Interpolant::kLinear,
    Interpolant::kPolynomial,      Interpolant::kNaturalSpline,
    Interpolant::kClampedSpline,   Interpolant::kPeriodicSpline,
    Interpolant::kNotAKnotSpline,  Interpolant::kHermite,
    Interpolant::kCatmullRom,      Interpolant::kCentripetalCatmullRom,
    Interpolant::kChordalCatmullRom, Interpolant::kKochanekBartels,
    Interpolant::kMonotone,
};

struct Result {
  RowMatrixXd samples, derivatives;
};

Result Sample(const Eigen::VectorXd& times, const RowMatrixXd& values,
              const InterpolationOptions& options, const Eigen::VectorXd& eval) {
  Result r{RowMatrixXd(eval.size(), values.cols()), RowMatrixXd(eval.size(), values.cols())};
  InterpolateJob job(times, values, options, eval, r.samples);
  job.derivatives.emplace(r.derivatives);
  const Status status = job.Validate();
  EXPECT_TRUE(status) << status.message();
  job.Run();
  return r;
}

Result Sample(const Eigen::VectorXd& times, const RowMatrixXd& values, Interpolant kind,
              const Eigen::VectorXd& eval) {
  InterpolationOptions options;
  options.interpolant = kind;
  return Sample(times, values, options, eval);
}

Eigen::VectorXd Vec(std::initializer_list<double> v) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(v.size()));
  std::copy(v.begin(), v.end(), out.data());
  return out;
}

RowMatrixXd Col(std::initializer_list<double> v) { return Vec(v); }

// Keys with uneven spacing and a loop-friendly last row (equal to the first),
// so every kind, periodic included, accepts them.
struct Keys {
  Eigen::VectorXd times;
  RowMatrixXd values;
  RowMatrixXd slopes;
  Eigen::VectorXd tension, continuity, bias;
};

Keys RandomKeys(Eigen::Index n, Eigen::Index d, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> gap(0.3, 2.0), value(-2.0, 2.0), tcb(-0.6, 0.6);
  Keys k{Eigen::VectorXd(n), RowMatrixXd(n, d), RowMatrixXd(n, d), Eigen::VectorXd(n),
         Eigen::VectorXd(n), Eigen::VectorXd(n)};
  double t = -1.5;
  for (Eigen::Index i = 0; i < n; ++i) {
    k.times[i] = t;
    t += gap(rng);
    for (Eigen::Index j = 0; j < d; ++j) {
      k.values(i, j) = value(rng);
      k.slopes(i, j) = value(rng);
    }
    k.tension[i] = tcb(rng);
    k.continuity[i] = tcb(rng);
    k.bias[i] = tcb(rng);
  }
  k.values.row(n - 1) = k.values.row(0);
  return k;
}

InterpolationOptions OptionsFor(Interpolant kind, const Keys& k) {
  InterpolationOptions o;
  o.interpolant = kind;
  if (kind == Interpolant::kHermite) o.slopes.emplace(k.slopes);
  if (kind == Interpolant::kKochanekBartels) {
    o.tension.emplace(k.tension);
    o.continuity.emplace(k.continuity);
    o.bias.emplace(k.bias);
  }
  return o;
}

TEST(Interpolation, NamesRoundTrip) {
  for (Interpolant kind : kAll) {
    EXPECT_EQ(ParseInterpolant(InterpolantName(kind)), kind) << InterpolantName(kind);
  }
  EXPECT_FALSE(ParseInterpolant("cubic"));
}

TEST(Interpolation, LinearByHand) {
  const Result r = Sample(Vec({0, 1, 3}), Col({0, 2, 0}), Interpolant::kLinear,
                          Vec({0.5, 2.0, 1.0, 3.0}));
  EXPECT_DOUBLE_EQ(r.samples(0, 0), 1.0);
  EXPECT_DOUBLE_EQ(r.samples(1, 0), 1.0);
  EXPECT_EQ(r.samples(2, 0), 2.0);
  EXPECT_EQ(r.samples(3, 0), 0.0);
  EXPECT_DOUBLE_EQ(r.derivatives(0, 0), 2.0);
  EXPECT_DOUBLE_EQ(r.derivatives(1, 0), -1.0);
  EXPECT_DOUBLE_EQ(r.derivatives(3, 0), -1.0);  // on the last key: the left derivative
}

TEST(Interpolation, SteppedHoldsTheLeftKey) {
  const Result r = Sample(Vec({0, 1, 3}), Col({5, 7, 9}), Interpolant::kStepped,
                          Vec({-1, 0, 0.99, 1, 2.5, 3, 4}));
  EXPECT_EQ(r.samples.col(0), Vec({5, 5, 5, 7, 7, 9, 9}));
  EXPECT_EQ(r.derivatives.col(0), Eigen::VectorXd::Zero(7));
}

TEST(Interpolation, PolynomialByHand) {
  // Through (0, 0), (1, 1), (3, 9): the parabola t^2.
  const Result r = Sample(Vec({0, 1, 3}), Col({0, 1, 9}), Interpolant::kPolynomial,
                          Vec({2.0, 1.0, 0.5, 3.0}));
  EXPECT_NEAR(r.samples(0, 0), 4.0, 1e-14);
  EXPECT_EQ(r.samples(1, 0), 1.0);
  EXPECT_NEAR(r.samples(2, 0), 0.25, 1e-14);
  EXPECT_NEAR(r.derivatives(0, 0), 4.0, 1e-13);
  EXPECT_NEAR(r.derivatives(1, 0), 2.0, 1e-13);  // on a node: the differentiation-matrix row
  EXPECT_NEAR(r.derivatives(3, 0), 6.0, 1e-13);
}

TEST(Interpolation, PolynomialShowsRunge) {
  // 1 / (1 + 25 t^2) at 15 even keys on [-1, 1]: the polynomial swings far
  // past the data near the ends, a natural spline does not.
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(15, -1.0, 1.0);
  RowMatrixXd y(15, 1);
  for (int i = 0; i < 15; ++i) y(i, 0) = 1.0 / (1.0 + 25.0 * t[i] * t[i]);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(1001, -1.0, 1.0);
  EXPECT_GT(Sample(t, y, Interpolant::kPolynomial, x).samples.cwiseAbs().maxCoeff(), 3.0);
  EXPECT_LT(Sample(t, y, Interpolant::kNaturalSpline, x).samples.cwiseAbs().maxCoeff(), 1.1);
}

TEST(Interpolation, NaturalSplineByHand) {
  // Keys (0, 0), (1, 1), (2, 0): slopes 1.5, 0, -1.5 (symmetry and S''(0) = 0).
  const Result r = Sample(Vec({0, 1, 2}), Col({0, 1, 0}), Interpolant::kNaturalSpline,
                          Vec({0.5, 0.0, 2.0}));
  EXPECT_NEAR(r.samples(0, 0), 0.6875, 1e-15);
  EXPECT_NEAR(r.derivatives(1, 0), 1.5, 1e-15);
  EXPECT_NEAR(r.derivatives(2, 0), -1.5, 1e-15);
  // Second derivative at the ends is 0: the slope is flat to first order there.
  const double h = 1e-4;
  const Result ends = Sample(Vec({0, 1, 2}), Col({0, 1, 0}), Interpolant::kNaturalSpline,
                             Vec({0.0, h, 2.0 - h, 2.0}));
  EXPECT_NEAR((ends.derivatives(1, 0) - ends.derivatives(0, 0)) / h, 0.0, 1e-3);
  EXPECT_NEAR((ends.derivatives(3, 0) - ends.derivatives(2, 0)) / h, 0.0, 1e-3);
}

double Cubic(double t) { return t * t * t - 2.0 * t + 1.0; }
double CubicSlope(double t) { return 3.0 * t * t - 2.0; }

TEST(Interpolation, ClampedAndNotAKnotReproduceACubic) {
  const Eigen::VectorXd t = Vec({-1.0, -0.2, 0.5, 1.7, 2.0, 3.1});
  RowMatrixXd y(6, 1);
  for (int i = 0; i < 6; ++i) y(i, 0) = Cubic(t[i]);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(97, -1.0, 3.1);
  const Eigen::VectorXd start = Vec({CubicSlope(-1.0)}), end = Vec({CubicSlope(3.1)});
  InterpolationOptions clamped;
  clamped.interpolant = Interpolant::kClampedSpline;
  clamped.start_slope.emplace(start);
  clamped.end_slope.emplace(end);
  for (const Result& r : {Sample(t, y, clamped, x), Sample(t, y, Interpolant::kNotAKnotSpline, x)}) {
    for (int s = 0; s < x.size(); ++s) {
      EXPECT_NEAR(r.samples(s, 0), Cubic(x[s]), 1e-12) << x[s];
      EXPECT_NEAR(r.derivatives(s, 0), CubicSlope(x[s]), 1e-11) << x[s];
    }
  }
}

TEST(Interpolation, NotAKnotWithThreeKeysIsTheParabola) {
  const Result r = Sample(Vec({0, 1, 3}), Col({0, 1, 9}), Interpolant::kNotAKnotSpline,
                          Vec({2.0, 0.5}));
  EXPECT_NEAR(r.samples(0, 0), 4.0, 1e-14);
  EXPECT_NEAR(r.samples(1, 0), 0.25, 1e-14);
  EXPECT_NEAR(r.derivatives(0, 0), 4.0, 1e-14);
}

TEST(Interpolation, ClampedDefaultsToFlatEnds) {
  const Result r = Sample(Vec({0, 1}), Col({0, 1}), Interpolant::kClampedSpline, Vec({0, 0.5, 1}));
  EXPECT_EQ(r.derivatives(0, 0), 0.0);
  EXPECT_NEAR(r.derivatives(2, 0), 0.0, 1e-15);
  EXPECT_NEAR(r.samples(1, 0), 0.5, 1e-15);  // smoothstep
}

TEST(Interpolation, PeriodicSplineIsC2AcrossTheWrap) {
  const int n = 9;
  const Eigen::VectorXd t = Vec({0.0, 0.5, 1.1, 2.0, 2.6, 3.5, 4.4, 5.0, 2.0 * std::acos(-1.0)});
  RowMatrixXd y(n, 2);
  for (int i = 0; i + 1 < n; ++i) {
    y(i, 0) = std::sin(t[i]);
    y(i, 1) = std::cos(t[i]) + 0.1 * i * (i - 8);
  }
  for (int j = 0; j < 2; ++j) y(n - 1, j) = y(0, j);  // exactly equal ends
  const double h = 1e-5, period = t[n - 1];
  const Result r = Sample(t, y, Interpolant::kPeriodicSpline, Vec({0.0, h, period - h, period}));
  for (int j = 0; j < 2; ++j) {
    EXPECT_NEAR(r.derivatives(0, j), r.derivatives(3, j), 1e-12);
    const double second_start = (r.derivatives(1, j) - r.derivatives(0, j)) / h;
    const double second_end = (r.derivatives(3, j) - r.derivatives(2, j)) / h;
    EXPECT_NEAR(second_start, second_end, 1e-3);
  }
}

TEST(Interpolation, HermiteWithTrueSlopesReproducesACubic) {
  const Eigen::VectorXd t = Vec({-1.0, 0.3, 2.0});
  RowMatrixXd y(3, 1), m(3, 1);
  for (int i = 0; i < 3; ++i) {
    y(i, 0) = Cubic(t[i]);
    m(i, 0) = CubicSlope(t[i]);
  }
  InterpolationOptions o;
  o.interpolant = Interpolant::kHermite;
  o.slopes.emplace(m);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(31, -1.0, 2.0);
  const Result r = Sample(t, y, o, x);
  for (int s = 0; s < x.size(); ++s) EXPECT_NEAR(r.samples(s, 0), Cubic(x[s]), 1e-13);
}

void HermiteForm(const Eigen::VectorXd& t, const RowMatrixXd& y, const InterpolationOptions& o,
                 RowMatrixXd& in, RowMatrixXd& out) {
  in.resize(y.rows(), y.cols());
  out.resize(y.rows(), y.cols());
  HermiteFormJob job(t, y, o, in, out);
  ASSERT_TRUE(job.Validate()) << job.Validate().message();
  job.Run();
}

TEST(Interpolation, CatmullRomSlopesByHand) {
  const Eigen::VectorXd t = Vec({0, 1, 3, 4});
  const RowMatrixXd y = Col({0, 2, 3, 7});
  InterpolationOptions o;
  o.interpolant = Interpolant::kCatmullRom;
  RowMatrixXd in, out;
  HermiteForm(t, y, o, in, out);
  EXPECT_EQ(out.col(0), Vec({2.0, 1.0, 5.0 / 3.0, 4.0}));
  EXPECT_EQ(in, out);
}

TEST(Interpolation, KochanekBartelsAtZeroIsCatmullRomExactly) {
  const Keys k = RandomKeys(12, 2, 5);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(301, -2.0, k.times[11] + 1.0);
  const Eigen::VectorXd zeros = Eigen::VectorXd::Zero(12);
  InterpolationOptions kb;
  kb.interpolant = Interpolant::kKochanekBartels;
  const Result cr = Sample(k.times, k.values, Interpolant::kCatmullRom, x);
  const Result absent = Sample(k.times, k.values, kb, x);
  kb.tension.emplace(zeros);
  kb.continuity.emplace(zeros);
  kb.bias.emplace(zeros);
  const Result given = Sample(k.times, k.values, kb, x);
  EXPECT_EQ(absent.samples, cr.samples);
  EXPECT_EQ(absent.derivatives, cr.derivatives);
  EXPECT_EQ(given.samples, cr.samples);
  EXPECT_EQ(given.derivatives, cr.derivatives);
}

TEST(Interpolation, KochanekBartelsParametersAct) {
  const Eigen::VectorXd t = Vec({0, 1, 2.5, 3});
  const RowMatrixXd y = Col({0, 1, 0, 2});
  RowMatrixXd in, out;
  Eigen::VectorXd c = Eigen::VectorXd::Zero(4);
  c[1] = 0.5;
  InterpolationOptions o;
  o.interpolant = Interpolant::kKochanekBartels;
  o.continuity.emplace(c);
  HermiteForm(t, y, o, in, out);
  EXPECT_NE(in(1, 0), out(1, 0));  // a corner
  EXPECT_EQ(in(2, 0), out(2, 0));
  // T = 1 at every key: all slopes vanish.
  const Eigen::VectorXd one = Eigen::VectorXd::Ones(4);
  InterpolationOptions tight;
  tight.interpolant = Interpolant::kKochanekBartels;
  tight.tension.emplace(one);
  HermiteForm(t, y, tight, in, out);
  EXPECT_EQ(in.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(out.cwiseAbs().maxCoeff(), 0.0);
  // Bias 1 at key 1 ((1+B) doubles the incoming chord, (1-B) drops the outgoing).
  Eigen::VectorXd b = Eigen::VectorXd::Zero(4);
  b[1] = 1.0;
  InterpolationOptions biased;
  biased.interpolant = Interpolant::kKochanekBartels;
  biased.bias.emplace(b);
  HermiteForm(t, y, biased, in, out);
  EXPECT_DOUBLE_EQ(out(1, 0), 2.0 * (1.0 - 0.0) / 2.5);
}

TEST(Interpolation, ChordalMatchesCatmullRomForEvenMotion) {
  // Keys evenly spaced in time and in space: chord knots are uniform too.
  const Eigen::VectorXd t = Vec({0, 1, 2, 3, 4});
  RowMatrixXd y(5, 2);
  for (int i = 0; i < 5; ++i) y.row(i) << i, -2.0 * i;
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(41, 0.0, 4.0);
  for (Interpolant kind : {Interpolant::kChordalCatmullRom, Interpolant::kCentripetalCatmullRom}) {
    const Result r = Sample(t, y, kind, x);
    for (int s = 0; s < x.size(); ++s) {
      EXPECT_NEAR(r.samples(s, 0), x[s], 1e-14);
      EXPECT_NEAR(r.samples(s, 1), -2.0 * x[s], 1e-14);
    }
  }
}

TEST(Interpolation, BarryGoldmanSlopesByHand) {
  // Chords of length 1 and 4 (chordal knots 0, 1, 5; centripetal 0, 1, 3).
  const Eigen::VectorXd t = Vec({0, 1, 2});
  const RowMatrixXd y = Col({0, 1, 5});
  RowMatrixXd in, out;
  InterpolationOptions o;
  o.interpolant = Interpolant::kCentripetalCatmullRom;
  HermiteForm(t, y, o, in, out);
  // dP/ds at key 1 = (2 * 1 + 1 * 2) / 3 = 4/3 (chord velocities 1 and 2);
  // times ds/dt: 1 on the left segment, 2 on the right.
  EXPECT_NEAR(in(1, 0), 4.0 / 3.0, 1e-15);
  EXPECT_NEAR(out(1, 0), 8.0 / 3.0, 1e-15);
  EXPECT_NEAR(out(0, 0), 1.0, 1e-15);
  EXPECT_NEAR(in(2, 0), 4.0, 1e-15);
}

TEST(Interpolation, CoincidentKeysGiveFlatSegmentsNotNaN) {
  const Eigen::VectorXd t = Vec({0, 1, 2, 3, 4});
  RowMatrixXd y(5, 2);
  y << 0, 0,  //
      1, 1,   //
      1, 1,   //
      1, 1,   //
      3, 0;
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(81, -1.0, 5.0);
  for (Interpolant kind : {Interpolant::kCentripetalCatmullRom, Interpolant::kChordalCatmullRom}) {
    const Result r = Sample(t, y, kind, x);
    EXPECT_TRUE(r.samples.allFinite());
    EXPECT_TRUE(r.derivatives.allFinite());
    for (int s = 0; s < x.size(); ++s) {
      if (x[s] >= 1.0 && x[s] <= 3.0) {
        EXPECT_EQ(r.samples.row(s), y.row(1)) << x[s];
      }
    }
    RowMatrixXd in, out;
    InterpolationOptions o;
    o.interpolant = kind;
    HermiteForm(t, y, o, in, out);
    // Key 3 leaves along its only chord, as an end key would.
    EXPECT_NEAR(out(3, 0) * (y(4, 1) - y(3, 1)), out(3, 1) * (y(4, 0) - y(3, 0)), 1e-15);
    EXPECT_GT(out(3, 0), 0.0);
    // All keys identical: a constant.
    const RowMatrixXd same = RowMatrixXd::Constant(5, 2, 0.25);
    const Result flat = Sample(t, same, kind, x);
    EXPECT_EQ(flat.samples, RowMatrixXd::Constant(81, 2, 0.25));
    EXPECT_EQ(flat.derivatives, RowMatrixXd::Zero(81, 2));
  }
}

TEST(Interpolation, MonotoneNeverOvershoots) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> gap(0.01, 3.0), step(0.0, 2.0);
  std::bernoulli_distribution flat(0.2);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 2 + trial % 30;
    Eigen::VectorXd t(n);
    RowMatrixXd y(n, 1);
    const double direction = trial % 2 ? 1.0 : -1.0;
    t[0] = 0.0;
    y(0, 0) = 0.0;
    for (int i = 1; i < n; ++i) {
      t[i] = t[i - 1] + gap(rng);
      y(i, 0) = y(i - 1, 0) + (flat(rng) ? 0.0 : direction * step(rng));
    }
    const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(20 * n, -1.0, t[n - 1] + 1.0);
    const Result r = Sample(t, y, Interpolant::kMonotone, x);
    for (int s = 0; s < x.size(); ++s) {
      const Eigen::Index k = std::min<Eigen::Index>(
          std::max<Eigen::Index>(std::upper_bound(t.data(), t.data() + n, x[s]) - t.data() - 1, 0),
          n - 2);
      const double lo = std::min(y(k, 0), y(k + 1, 0)), hi = std::max(y(k, 0), y(k + 1, 0));
      EXPECT_GE(r.samples(s, 0), lo - 1e-12) << "trial " << trial << " t " << x[s];
      EXPECT_LE(r.samples(s, 0), hi + 1e-12) << "trial " << trial << " t " << x[s];
      EXPECT_GE(direction * r.derivatives(s, 0), -1e-12);
    }
  }
}

TEST(Interpolation, EveryKindPassesThroughItsKeysExactlyAndHoldsOutside) {
  const Keys k = RandomKeys(9, 3, 1);
  Eigen::VectorXd x(9 + 2);
  x << k.times, k.times[0] - 3.0, k.times[8] + 0.5;
  for (Interpolant kind : kAll) {
    const Result r = Sample(k.times, k.values, OptionsFor(kind, k), x);
    EXPECT_EQ(r.samples.topRows(9), k.values) << InterpolantName(kind);
    EXPECT_EQ(r.samples.row(9), k.values.row(0)) << InterpolantName(kind);
    EXPECT_EQ(r.samples.row(10), k.values.row(8)) << InterpolantName(kind);
    EXPECT_EQ(r.derivatives.bottomRows(2), RowMatrixXd::Zero(2, 3)) << InterpolantName(kind);
  }
}

TEST(Interpolation, DerivativesMatchFiniteDifferences) {
  const Keys k = RandomKeys(8, 2, 3);
  // Times between keys, away from them by more than the step.
  std::vector<double> mids;
  for (int i = 0; i + 1 < 8; ++i) {
    for (double f : {0.2, 0.5, 0.77}) mids.push_back(k.times[i] + f * (k.times[i + 1] - k.times[i]));
  }
  const Eigen::Index m = static_cast<Eigen::Index>(mids.size());
  const double h = 1e-6;
  Eigen::VectorXd x(m), plus(m), minus(m);
  for (Eigen::Index s = 0; s < m; ++s) {
    x[s] = mids[s];
    plus[s] = mids[s] + h;
    minus[s] = mids[s] - h;
  }
  for (Interpolant kind : kAll) {
    const InterpolationOptions o = OptionsFor(kind, k);
    const Result r = Sample(k.times, k.values, o, x);
    const RowMatrixXd fd =
        (Sample(k.times, k.values, o, plus).samples - Sample(k.times, k.values, o, minus).samples) /
        (2.0 * h);
    const double scale = 1.0 + fd.cwiseAbs().maxCoeff();
    EXPECT_LT((r.derivatives - fd).cwiseAbs().maxCoeff(), 1e-6 * scale) << InterpolantName(kind);
  }
}

TEST(Interpolation, UnsortedTimesGiveTheSameSamples) {
  const Keys k = RandomKeys(20, 2, 4);
  const Eigen::VectorXd sorted = Eigen::VectorXd::LinSpaced(500, k.times[0] - 1.0, k.times[19] + 1.0);
  std::vector<Eigen::Index> order(500);
  for (Eigen::Index s = 0; s < 500; ++s) order[s] = s;
  std::shuffle(order.begin(), order.end(), std::mt19937(9));
  Eigen::VectorXd shuffled(500);
  for (Eigen::Index s = 0; s < 500; ++s) shuffled[s] = sorted[order[s]];
  for (Interpolant kind : kAll) {
    const InterpolationOptions o = OptionsFor(kind, k);
    const Result a = Sample(k.times, k.values, o, sorted);
    const Result b = Sample(k.times, k.values, o, shuffled);
    for (Eigen::Index s = 0; s < 500; ++s) {
      EXPECT_EQ(b.samples.row(s), a.samples.row(order[s])) << InterpolantName(kind);
      EXPECT_EQ(b.derivatives.row(s), a.derivatives.row(order[s])) << InterpolantName(kind);
    }
  }
}

TEST(Interpolation, OneKeyIsAConstant) {
  for (Interpolant kind : kAll) {
    const Keys k = RandomKeys(1, 2, 6);
    const Result r = Sample(k.times, k.values, OptionsFor(kind, k), Vec({-5, k.times[0], 7}));
    EXPECT_EQ(r.samples, k.values.replicate(3, 1)) << InterpolantName(kind);
    EXPECT_EQ(r.derivatives, RowMatrixXd::Zero(3, 2)) << InterpolantName(kind);
  }
}

TEST(Interpolation, TwoKeysAreALineForTheSecantKinds) {
  const Eigen::VectorXd t = Vec({1, 3});
  const RowMatrixXd y = Col({2, 6});
  const Eigen::VectorXd x = Vec({1.5, 2, 2.5});
  for (Interpolant kind :
       {Interpolant::kLinear, Interpolant::kPolynomial, Interpolant::kNaturalSpline,
        Interpolant::kNotAKnotSpline, Interpolant::kCatmullRom, Interpolant::kCentripetalCatmullRom,
        Interpolant::kChordalCatmullRom, Interpolant::kKochanekBartels, Interpolant::kMonotone}) {
    const Result r = Sample(t, y, kind, x);
    for (int s = 0; s < 3; ++s) {
      EXPECT_NEAR(r.samples(s, 0), 2.0 * x[s], 1e-14) << InterpolantName(kind);
      EXPECT_NEAR(r.derivatives(s, 0), 2.0, 1e-14) << InterpolantName(kind);
    }
  }
}

// Evaluates the Hermite form directly with the Hermite basis functions (docs/resampling.md).
double HermiteValue(const Eigen::VectorXd& t, const RowMatrixXd& y, const RowMatrixXd& in,
                    const RowMatrixXd& out, Eigen::Index j, double x) {
  const Eigen::Index n = t.size();
  if (x <= t[0]) return y(0, j);
  if (x >= t[n - 1]) return y(n - 1, j);
  const Eigen::Index k = std::upper_bound(t.data(), t.data() + n, x) - t.data() - 1;
  const double h = t[k + 1] - t[k], u = (x - t[k]) / h;
  const double h00 = 2 * u * u * u - 3 * u * u + 1, h01 = -2 * u * u * u + 3 * u * u;
  const double h10 = u * u * u - 2 * u * u + u, h11 = u * u * u - u * u;
  return h00 * y(k, j) + h01 * y(k + 1, j) + h * (h10 * out(k, j) + h11 * in(k + 1, j));
}

TEST(Interpolation, HermiteFormReproducesTheCurve) {
  const Keys k = RandomKeys(10, 2, 8);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(333, k.times[0] - 0.5, k.times[9] + 0.5);
  for (Interpolant kind : kAll) {
    if (!IsHermiteForm(kind)) continue;
    const InterpolationOptions o = OptionsFor(kind, k);
    RowMatrixXd in, out;
    HermiteForm(k.times, k.values, o, in, out);
    EXPECT_EQ(in.row(0), out.row(0)) << InterpolantName(kind);
    EXPECT_EQ(in.row(9), out.row(9)) << InterpolantName(kind);
    const Result r = Sample(k.times, k.values, o, x);
    for (Eigen::Index s = 0; s < x.size(); ++s) {
      for (Eigen::Index j = 0; j < 2; ++j) {
        EXPECT_NEAR(r.samples(s, j), HermiteValue(k.times, k.values, in, out, j, x[s]), 1e-12)
            << InterpolantName(kind) << " at " << x[s];
      }
    }
  }
}

TEST(Interpolation, LinearHermiteFormIsTheSecants) {
  RowMatrixXd in, out;
  InterpolationOptions o;
  o.interpolant = Interpolant::kLinear;
  HermiteForm(Vec({0, 1, 3}), Col({0, 2, 0}), o, in, out);
  EXPECT_EQ(out.col(0), Vec({2, -1, -1}));
  EXPECT_EQ(in.col(0), Vec({2, 2, -1}));
}

TEST(Interpolation, BatchEqualsOneCurveAtATime) {
  // Curves of 1 to 9 keys, scalar, each kind; batch rows against single jobs.
  const int curves = 9;
  std::vector<Keys> keys;
  Eigen::VectorXi offsets(curves + 1);
  offsets[0] = 0;
  for (int c = 0; c < curves; ++c) {
    keys.push_back(RandomKeys(c + 1, 1, 20 + c));
    offsets[c + 1] = offsets[c] + c + 1;
  }
  const int total = offsets[curves];
  Eigen::VectorXd times(total), values(total), slopes(total), tension(total), continuity(total),
      bias(total), starts(curves), ends(curves);
  for (int c = 0; c < curves; ++c) {
    const int n = c + 1, first = offsets[c];
    times.segment(first, n) = keys[c].times;
    values.segment(first, n) = keys[c].values.col(0);
    slopes.segment(first, n) = keys[c].slopes.col(0);
    tension.segment(first, n) = keys[c].tension;
    continuity.segment(first, n) = keys[c].continuity;
    bias.segment(first, n) = keys[c].bias;
    starts[c] = 0.5 * c;
    ends[c] = -0.25 * c;
  }
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(257, -3.0, 14.0);
  const Eigen::Map<const RowMatrixXd> slope_column(slopes.data(), total, 1);
  for (Interpolant kind : kAll) {
    InterpolationOptions batch;
    batch.interpolant = kind;
    batch.slopes.emplace(slope_column);
    batch.tension.emplace(tension);
    batch.continuity.emplace(continuity);
    batch.bias.emplace(bias);
    batch.start_slope.emplace(starts);
    batch.end_slope.emplace(ends);
    RowMatrixXd samples(curves, x.size()), derivatives(curves, x.size());
    InterpolateCurvesJob job(offsets, times, values, batch, x, samples);
    job.derivatives.emplace(derivatives);
    ASSERT_TRUE(job.Validate()) << job.Validate().message();
    job.Run();
    for (int c = 0; c < curves; ++c) {
      InterpolationOptions single = OptionsFor(kind, keys[c]);
      const Eigen::VectorXd start = starts.segment(c, 1), end = ends.segment(c, 1);
      single.start_slope.emplace(start);
      single.end_slope.emplace(end);
      const Result r = Sample(keys[c].times, keys[c].values, single, x);
      const double scale = 1.0 + r.samples.cwiseAbs().maxCoeff() + r.derivatives.cwiseAbs().maxCoeff();
      EXPECT_LE((samples.row(c).transpose() - r.samples.col(0)).cwiseAbs().maxCoeff(), 1e-14 * scale)
          << InterpolantName(kind) << " curve " << c;
      EXPECT_LE((derivatives.row(c).transpose() - r.derivatives.col(0)).cwiseAbs().maxCoeff(),
                1e-14 * scale)
          << InterpolantName(kind) << " curve " << c;
    }
  }
}

std::string Message(const Eigen::VectorXd& t, const RowMatrixXd& y, const InterpolationOptions& o,
                    const Eigen::VectorXd& x) {
  RowMatrixXd out(x.size(), y.cols());
  InterpolateJob job(t, y, o, x, out);
  const Status status = job.Validate();
  EXPECT_FALSE(status);
  EXPECT_THROW(job.Run(), Error);
  return status.message();
}

TEST(Interpolation, RejectsBadKeysNamingThem) {
  InterpolationOptions o;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(Message(Vec({0, 1, 1}), Col({0, 1, 2}), o, Vec({0})),
            "interpolate: key times must increase strictly, but key 2 (1.000000) does not come "
            "after key 1 (1.000000)");
  EXPECT_EQ(Message(Vec({0, inf}), Col({0, 1}), o, Vec({0})),
            "interpolate: time of key 1 is not finite");
  RowMatrixXd y = RowMatrixXd::Zero(3, 2);
  y(2, 1) = nan;
  EXPECT_EQ(Message(Vec({0, 1, 2}), y, o, Vec({0})),
            "interpolate: value of key 2 (time 2.000000), component 1 is not finite");
  EXPECT_EQ(Message(Vec({0, 1, 2}), Col({0, 1, 2}), o, Vec({0, nan})),
            "interpolate: eval time 1 is not finite");
  EXPECT_EQ(Message(Eigen::VectorXd(0), RowMatrixXd(0, 1), o, Vec({0})),
            "interpolate: there are no keys");
  EXPECT_EQ(Message(Vec({0, 1, 2}), Col({0, 1}), o, Vec({0})),
            "interpolate: values must be 3 x d (d >= 1, one row per key time), got 2 x 1");
}

TEST(Interpolation, RejectsBadOptions) {
  InterpolationOptions periodic;
  periodic.interpolant = Interpolant::kPeriodicSpline;
  RowMatrixXd loop(3, 2);
  loop << 0, 1,  //
      2, 2,      //
      0, 1.5;
  EXPECT_EQ(Message(Vec({0, 1, 2}), loop, periodic, Vec({0})),
            "interpolate: a periodic spline needs the last key equal to the first, but component "
            "1 is 1.000000 at key 0 and 1.500000 at key 2");
  InterpolationOptions hermite;
  hermite.interpolant = Interpolant::kHermite;
  EXPECT_EQ(Message(Vec({0, 1}), Col({0, 1}), hermite, Vec({0})),
            "interpolate: hermite needs slopes, one per key and component");
  const RowMatrixXd bad_slopes = Col({0, std::numeric_limits<double>::quiet_NaN()});
  hermite.slopes.emplace(bad_slopes);
  EXPECT_EQ(Message(Vec({0, 1}), Col({0, 1}), hermite, Vec({0})),
            "interpolate: hermite slope of key 1 is not finite");
  InterpolationOptions kb;
  kb.interpolant = Interpolant::kKochanekBartels;
  const Eigen::VectorXd short_tension = Vec({0, 0});
  kb.tension.emplace(short_tension);
  EXPECT_EQ(Message(Vec({0, 1, 2}), Col({0, 1, 2}), kb, Vec({0})),
            "interpolate: tension must have 3 entries (one per key) or none, got 2");
  InterpolationOptions clamped;
  clamped.interpolant = Interpolant::kClampedSpline;
  const Eigen::VectorXd one = Vec({1});
  clamped.end_slope.emplace(one);
  EXPECT_EQ(Message(Vec({0, 1, 2}), RowMatrixXd::Zero(3, 2), clamped, Vec({0})),
            "interpolate: clamped end_slope must have 2 entries, got 1");
}

TEST(Interpolation, HermiteFormRefusesStepsAndPolynomials) {
  RowMatrixXd in(2, 1), out(2, 1);
  InterpolationOptions o;
  o.interpolant = Interpolant::kStepped;
  const Eigen::VectorXd t = Vec({0, 1});
  const RowMatrixXd y = Col({0, 1});
  HermiteFormJob stepped(t, y, o, in, out);
  EXPECT_NE(stepped.Validate().message().find("write them as CONSTANT keys"), std::string::npos);
  o.interpolant = Interpolant::kPolynomial;
  HermiteFormJob polynomial(t, y, o, in, out);
  EXPECT_NE(polynomial.Validate().message().find("sample it instead"), std::string::npos);
  EXPECT_THROW(polynomial.Run(), Error);
}

TEST(Interpolation, BatchNamesTheCurve) {
  Eigen::VectorXi offsets(3);
  offsets << 0, 2, 5;
  const Eigen::VectorXd times = Vec({0, 1, 0, 2, 2});
  const Eigen::VectorXd values = Vec({0, 1, 2, 3, 4});
  RowMatrixXd out(2, 1);
  InterpolateCurvesJob job(offsets, times, values, InterpolationOptions{}, Vec({0}), out);
  EXPECT_EQ(job.Validate().message(),
            "interpolate curves: curve 1, key times must increase strictly, but key 2 (2.000000) "
            "does not come after key 1 (2.000000)");
  Eigen::VectorXi empty(3);
  empty << 0, 2, 2;
  InterpolateCurvesJob none(empty, times.head(2), values.head(2), InterpolationOptions{}, Vec({0}),
                            out);
  EXPECT_EQ(none.Validate().message(), "interpolate curves: curve 1 has no keys (offsets 2, 2)");
}

}  // namespace
}  // namespace motionkit
