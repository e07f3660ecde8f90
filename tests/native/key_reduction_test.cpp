#include "motionkit/key_reduction.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>

namespace motionkit {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Reduced {
  std::vector<std::int64_t> keys;
  RowMatrixXd slopes_in, slopes_out;  // one row per key
};

Reduced Reduce(const Eigen::VectorXd& times, const RowMatrixXd& values, double tolerance,
               KeyToleranceMode mode = KeyToleranceMode::kAbsolute,
               EulerOrder order = EulerOrder::kXYZ, Eigen::Index stride = 1) {
  const Eigen::Index m = times.size(), d = values.cols();
  Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1> indices(m);
  RowMatrixXd in(m, d), out(m, d);
  KeyReductionJob job(times, values, tolerance, indices, in, out);
  job.mode = mode;
  job.euler_order = order;
  job.stride = stride;
  const Status status = job.Validate();
  EXPECT_TRUE(status) << status.message();
  job.Run();
  Reduced r{std::vector<std::int64_t>(indices.data(), indices.data() + job.key_count),
            in.topRows(job.key_count), out.topRows(job.key_count)};
  return r;
}

// The reduced curve at every sample, as Blender draws it: per segment a cubic
// Bézier whose handles sit at one third of the segment, evaluated with the
// Bernstein polynomials (not the Hermite form the reduction uses).
RowMatrixXd Redraw(const Eigen::VectorXd& times, const RowMatrixXd& values, const Reduced& r) {
  RowMatrixXd out(times.size(), values.cols());
  std::size_t k = 0;
  for (Eigen::Index j = 0; j < times.size(); ++j) {
    while (k + 2 < r.keys.size() && j >= r.keys[k + 1]) ++k;
    if (r.keys.size() == 1) {
      out.row(j) = values.row(0);
      continue;
    }
    const Eigen::Index a = r.keys[k], b = r.keys[k + 1];
    const double h = times[b] - times[a], u = (times[j] - times[a]) / h, v = 1 - u;
    for (Eigen::Index c = 0; c < values.cols(); ++c) {
      const double p0 = values(a, c), p3 = values(b, c);
      const double p1 = p0 + r.slopes_out(static_cast<Eigen::Index>(k), c) * h / 3;
      const double p2 = p3 - r.slopes_in(static_cast<Eigen::Index>(k + 1), c) * h / 3;
      out(j, c) = v * v * v * p0 + 3 * v * v * u * p1 + 3 * v * u * u * p2 + u * u * u * p3;
    }
  }
  return out;
}

double AngleBetween(Eigen::Quaterniond p, Eigen::Quaterniond q) {
  p.normalize();
  q.normalize();
  return Eigen::AngleAxisd(p.conjugate() * q).angle() > kPi
             ? 2 * kPi - Eigen::AngleAxisd(p.conjugate() * q).angle()
             : Eigen::AngleAxisd(p.conjugate() * q).angle();
}

void ExpectEnds(const Reduced& r, Eigen::Index m) {
  ASSERT_FALSE(r.keys.empty());
  EXPECT_EQ(r.keys.front(), 0);
  EXPECT_EQ(r.keys.back(), m - 1);
  for (std::size_t k = 1; k < r.keys.size(); ++k) EXPECT_LT(r.keys[k - 1], r.keys[k]);
}

TEST(KeyReductionJob, StraightLineNeedsTwoKeys) {
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(1000, 0.0, 41.625);
  RowMatrixXd y(1000, 2);
  y.col(0) = 3.0 * t.array() - 2.0;
  y.col(1) = -0.5 * t.array() + 7.0;
  const Reduced r = Reduce(t, y, 1e-9);
  ASSERT_EQ(r.keys.size(), 2u);
  ExpectEnds(r, 1000);
  EXPECT_NEAR(r.slopes_out(0, 0), 3.0, 1e-9);
  EXPECT_NEAR(r.slopes_in(1, 1), -0.5, 1e-9);
  EXPECT_LE((Redraw(t, y, r) - y).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(KeyReductionJob, SampledCubicNeedsTwoKeys) {
  // Uneven sampling on purpose.
  Eigen::VectorXd t(500);
  for (int j = 0; j < 500; ++j) t[j] = 2.0 + 3.0 * std::pow(j / 499.0, 1.5);
  RowMatrixXd y(500, 1);
  for (int j = 0; j < 500; ++j) y(j, 0) = 0.3 * std::pow(t[j], 3) - 2 * t[j] * t[j] + t[j] - 4;
  const Reduced r = Reduce(t, y, 1e-9);
  ASSERT_EQ(r.keys.size(), 2u);
  // The exact end slopes of the cubic.
  EXPECT_NEAR(r.slopes_out(0, 0), 0.9 * 4 - 4 * 2 + 1, 1e-7);
  EXPECT_NEAR(r.slopes_in(1, 0), 0.9 * 25 - 4 * 5 + 1, 1e-7);
}

TEST(KeyReductionJob, SineNeedsFarFewerKeysAndStaysWithinTolerance) {
  const int m = 4 * 1000;  // 1000 frames sampled 4 times per frame
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(m, 1.0, 1000.75);
  RowMatrixXd y(m, 3);
  for (int j = 0; j < m; ++j) {
    y(j, 0) = std::sin(t[j] / 20.0);
    y(j, 1) = 0.5 * std::cos(t[j] / 7.0) + 0.01 * t[j];
    y(j, 2) = std::sin(t[j] / 50.0) * std::sin(t[j] / 3.0);
  }
  for (double tolerance : {1e-2, 1e-4}) {
    const Reduced r = Reduce(t, y, tolerance);
    ExpectEnds(r, m);
    EXPECT_LT(r.keys.size(), static_cast<std::size_t>(m / 8)) << tolerance;
    EXPECT_LE((Redraw(t, y, r) - y).cwiseAbs().maxCoeff(), tolerance * (1 + 1e-9)) << tolerance;
    // One plain sine, 8 periods: about a key per 9 frames at 1e-4.
    const RowMatrixXd sine = y.col(0);
    const Reduced s = Reduce(t, sine, tolerance);
    EXPECT_LT(s.keys.size(), static_cast<std::size_t>(m / 30)) << tolerance;
    EXPECT_LE((Redraw(t, sine, s) - sine).cwiseAbs().maxCoeff(), tolerance * (1 + 1e-9));
  }
}

TEST(KeyReductionJob, StrideKeepsKeysOnFramesAndStillChecksEverySample) {
  // 400 frames and a bit, 4 samples per frame: keys only on whole frames.
  const int m = 4 * 400 + 3;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(m, 1.0, 1.0 + (m - 1) / 4.0);
  RowMatrixXd y(m, 1);
  for (int j = 0; j < m; ++j) y(j, 0) = std::sin(t[j] / 9.0) + 0.2 * std::sin(t[j] / 2.0);
  // Tolerance 0 cannot be met between frames: keys fall between them then.
  for (double tolerance : {1e-2, 1e-4, 0.0}) {
    const Reduced r = Reduce(t, y, tolerance, KeyToleranceMode::kAbsolute, EulerOrder::kXYZ, 4);
    ExpectEnds(r, m);
    if (tolerance > 0) {
      for (std::size_t k = 0; k + 1 < r.keys.size(); ++k) EXPECT_EQ(r.keys[k] % 4, 0) << tolerance;
    }
    EXPECT_LE((Redraw(t, y, r) - y).cwiseAbs().maxCoeff(), tolerance * (1 + 1e-9) + 1e-12) << tolerance;
  }
}

TEST(KeyReductionJob, QuaternionModeHonoursTheAngle) {
  const int m = 3000;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(m, 0.0, 749.75);
  RowMatrixXd q(m, 4);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> phase(0.0, 2 * kPi);
  const double p0 = phase(rng), p1 = phase(rng), p2 = phase(rng);
  Eigen::Quaterniond previous = Eigen::Quaterniond::Identity();
  for (int j = 0; j < m; ++j) {
    const Eigen::Quaterniond r =
        Eigen::AngleAxisd(1.5 * std::sin(t[j] / 31 + p0), Eigen::Vector3d::UnitZ()) *
        Eigen::AngleAxisd(0.8 * std::sin(t[j] / 17 + p1), Eigen::Vector3d::UnitX()) *
        Eigen::AngleAxisd(2.0 * std::sin(t[j] / 43 + p2), Eigen::Vector3d::UnitY());
    Eigen::Quaterniond s = r;
    if (s.dot(previous) < 0) s.coeffs() = -s.coeffs();  // as a Blender quaternion curve is kept
    previous = s;
    q.row(j) << s.w(), s.x(), s.y(), s.z();
  }
  for (double tolerance : {1e-2, 1e-3}) {
    const Reduced r = Reduce(t, q, tolerance, KeyToleranceMode::kQuaternion);
    ExpectEnds(r, m);
    EXPECT_LT(r.keys.size(), static_cast<std::size_t>(m / 10));
    const RowMatrixXd redrawn = Redraw(t, q, r);
    double worst = 0;
    for (int j = 0; j < m; ++j) {
      worst = std::max(worst, AngleBetween(Eigen::Quaterniond(redrawn(j, 0), redrawn(j, 1), redrawn(j, 2), redrawn(j, 3)),
                                           Eigen::Quaterniond(q(j, 0), q(j, 1), q(j, 2), q(j, 3))));
    }
    EXPECT_LE(worst, tolerance * (1 + 1e-6)) << tolerance;
  }
}

TEST(KeyReductionJob, EulerModeHonoursTheAngle) {
  const int m = 2000;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(m, 0.0, 499.75);
  RowMatrixXd e(m, 3);
  for (int j = 0; j < m; ++j) {
    e.row(j) << 2.0 * std::sin(t[j] / 40), 1.2 * std::sin(t[j] / 23 + 1), 0.02 * t[j];
  }
  for (EulerOrder order : {EulerOrder::kXYZ, EulerOrder::kZYX}) {
    const double tolerance = 2e-3;
    const Reduced r = Reduce(t, e, tolerance, KeyToleranceMode::kEuler, order);
    ExpectEnds(r, m);
    EXPECT_LT(r.keys.size(), static_cast<std::size_t>(m / 10));
    const RowMatrixXd redrawn = Redraw(t, e, r);
    double worst = 0;
    for (int j = 0; j < m; ++j) {
      worst = std::max(worst, AngleBetween(EulerToQuaternion(redrawn.row(j).transpose(), order),
                                           EulerToQuaternion(e.row(j).transpose(), order)));
    }
    EXPECT_LE(worst, tolerance * (1 + 1e-6));
  }
}

TEST(KeyReductionJob, TinyAndConstantInputs) {
  {
    const Eigen::VectorXd t = Eigen::VectorXd::Constant(1, 5.0);
    const RowMatrixXd y = RowMatrixXd::Constant(1, 2, 3.0);
    const Reduced r = Reduce(t, y, 0.1);
    ASSERT_EQ(r.keys.size(), 1u);
    EXPECT_EQ(r.keys[0], 0);
    EXPECT_EQ(r.slopes_in.norm(), 0.0);
    EXPECT_EQ(r.slopes_out.norm(), 0.0);
  }
  {
    Eigen::VectorXd t(2);
    t << 1.0, 3.0;
    RowMatrixXd y(2, 1);
    y << 1.0, 5.0;
    const Reduced r = Reduce(t, y, 0.0);
    ASSERT_EQ(r.keys.size(), 2u);
    EXPECT_EQ(r.slopes_out(0, 0), 2.0);
    EXPECT_EQ(r.slopes_in(1, 0), 2.0);
    EXPECT_EQ(r.slopes_in(0, 0), 2.0);
    EXPECT_EQ(r.slopes_out(1, 0), 2.0);
  }
  {
    const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(300, 0.0, 10.0);
    const RowMatrixXd y = RowMatrixXd::Constant(300, 4, 0.5);  // also a valid quaternion
    for (KeyToleranceMode mode : {KeyToleranceMode::kAbsolute, KeyToleranceMode::kQuaternion}) {
      const Reduced r = Reduce(t, y, 0.0, mode);
      ASSERT_EQ(r.keys.size(), 2u);
      EXPECT_LT(r.slopes_out.norm(), 1e-15);
    }
  }
}

TEST(KeyReductionJob, ZeroToleranceKeepsNoisySamples) {
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(50, 0.0, 1.0);
  RowMatrixXd y(50, 1);
  std::mt19937 rng(1);
  std::normal_distribution<double> noise;
  for (int j = 0; j < 50; ++j) y(j, 0) = noise(rng);
  const Reduced r = Reduce(t, y, 0.0);
  EXPECT_EQ(r.keys.size(), 50u);
  EXPECT_EQ(Redraw(t, y, r), y);
}

TEST(KeyReductionJob, RejectsBadInputNamingTheSample) {
  Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(5, 0.0, 4.0);
  RowMatrixXd y = RowMatrixXd::Zero(5, 4);
  y.col(0).setOnes();
  Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1> indices(5);
  RowMatrixXd in(5, 4), out(5, 4);
  {
    RowMatrixXd bad = y;
    bad(3, 2) = std::numeric_limits<double>::quiet_NaN();
    KeyReductionJob job(t, bad, 0.1, indices, in, out);
    EXPECT_EQ(job.Validate().message(), "key reduction: channel 2 of sample 3 (time 3.000000) is not finite");
    EXPECT_THROW(job.Run(), Error);
  }
  {
    RowMatrixXd bad = y;
    bad.row(1).setZero();
    KeyReductionJob job(t, bad, 0.1, indices, in, out);
    EXPECT_TRUE(job.Validate());
    job.mode = KeyToleranceMode::kQuaternion;
    EXPECT_EQ(job.Validate().message(), "key reduction: quaternion of sample 1 (time 1.000000) is zero");
    job.mode = KeyToleranceMode::kEuler;
    EXPECT_EQ(job.Validate().message(), "key reduction: Euler mode needs 3 channels, got 4");
  }
  {
    Eigen::VectorXd bad = t;
    bad[4] = 2.5;
    KeyReductionJob job(bad, y, 0.1, indices, in, out);
    EXPECT_NE(job.Validate().message().find("sample 4 (2.500000) does not come after sample 3"), std::string::npos);
  }
  {
    KeyReductionJob job(t, y, -1.0, indices, in, out);
    EXPECT_EQ(job.Validate().message(), "key reduction: tolerance must be finite and >= 0, got -1.000000");
  }
  {
    RowMatrixXd small(4, 4);
    KeyReductionJob job(t, y, 0.1, indices, in, small);
    EXPECT_NE(job.Validate().message().find("outputs must be"), std::string::npos);
  }
  {
    const Eigen::VectorXd none;
    const RowMatrixXd no_values(0, 4);
    KeyReductionJob job(none, no_values, 0.1, indices, in, out);
    EXPECT_EQ(job.Validate().message(), "key reduction: no samples");
  }
}

TEST(KeyReductionJob, HundredThousandSamplesFinishQuickly) {
  // Not a timing assertion: a quadratic search would take minutes here.
  const int m = 100000;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(m, 0.0, 24999.75);
  RowMatrixXd y(m, 1);
  for (int j = 0; j < m; ++j) y(j, 0) = std::sin(t[j] / 30.0) + 0.3 * std::sin(t[j] / 7.0);
  const Reduced r = Reduce(t, y, 1e-3);
  ExpectEnds(r, m);
  EXPECT_LE((Redraw(t, y, r) - y).cwiseAbs().maxCoeff(), 1e-3 * (1 + 1e-9));
}

}  // namespace
}  // namespace motionkit
