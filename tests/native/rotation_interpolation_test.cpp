#include "motionkit/rotation_interpolation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <string>

namespace motionkit {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr std::array<RotationInterpolant, 4> kSphereKinds = {
    RotationInterpolant::kSlerp, RotationInterpolant::kSquad, RotationInterpolant::kCatmullRom,
    RotationInterpolant::kKochanekBartels};
constexpr std::array<RotationInterpolant, 6> kAllKinds = {
    RotationInterpolant::kSlerp,           RotationInterpolant::kSquad,
    RotationInterpolant::kCatmullRom,      RotationInterpolant::kKochanekBartels,
    RotationInterpolant::kEulerCatmullRom, RotationInterpolant::kAxisAngleCatmullRom};

std::string Name(RotationInterpolant kind) { return RotationInterpolantName(kind); }

Eigen::Quaterniond Row(const RowMatrixXd& q, Eigen::Index i) {
  return Eigen::Quaterniond(q(i, 0), q(i, 1), q(i, 2), q(i, 3));
}

// Angle between two rotations, q and -q alike.
double Angle(const Eigen::Quaterniond& p, const Eigen::Quaterniond& q) {
  Eigen::Vector4d a = p.coeffs().normalized(), b = q.coeffs().normalized();
  if (a.dot(b) < 0) b = -b;
  return 4.0 * std::atan2((a - b).norm(), (a + b).norm());
}

// Random smooth-ish keys: a wandering rotation with random signs and lengths.
struct Keys {
  Eigen::VectorXd times;
  RowMatrixXd quats;
};

Keys RandomKeys(int n, unsigned seed, bool uneven) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Keys k{Eigen::VectorXd(n), RowMatrixXd(n, 4)};
  Eigen::Quaterniond q = Eigen::Quaterniond::UnitRandom();
  double t = 0.3;
  for (int i = 0; i < n; ++i) {
    k.times[i] = t;
    t += uneven ? 0.2 + 1.5 * (unit(rng) + 1.0) : 0.5;
    const double sign = unit(rng) < 0 ? -1.0 : 1.0;
    const double length = 0.5 + (unit(rng) + 1.0);
    k.quats.row(i) << sign * length * q.w(), sign * length * q.x(), sign * length * q.y(),
        sign * length * q.z();
    const Eigen::Vector3d axis = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
    q = q * Eigen::Quaterniond(Eigen::AngleAxisd(0.9 * (unit(rng) + 1.2), axis));
  }
  return k;
}

struct Curve {
  RowMatrixXd q;
  RowMatrixXd w;
};

Curve Evaluate(const Keys& k, const Eigen::VectorXd& at, RotationInterpolant kind,
               const KeyTcb& tcb = KeyTcb(), EulerOrder order = EulerOrder::kXYZ) {
  Curve c{RowMatrixXd(at.size(), 4), RowMatrixXd(at.size(), 3)};
  RotationInterpolateJob job(k.times, k.quats, at, c.q, c.w, tcb);
  job.options.kind = kind;
  job.options.euler_order = order;
  const Status status = job.Validate();
  EXPECT_TRUE(status) << status.message();
  job.Run();
  return c;
}

Eigen::VectorXd Dense(const Keys& k, int count) {
  return Eigen::VectorXd::LinSpaced(count, k.times[0] - 0.5, k.times[k.times.size() - 1] + 0.5);
}

TEST(RotationInterpolant, NamesRoundTrip) {
  for (RotationInterpolant kind : kAllKinds) {
    const auto parsed = ParseRotationInterpolant(RotationInterpolantName(kind));
    ASSERT_TRUE(parsed.has_value());
    EXPECT_EQ(*parsed, kind);
    EXPECT_NE(std::string(RotationInterpolantNames()).find(Name(kind)), std::string::npos);
  }
  EXPECT_FALSE(ParseRotationInterpolant("Slerp").has_value());
  EXPECT_FALSE(ParseRotationInterpolant("").has_value());
}

TEST(Slerp, MatchesTheClosedForm) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Quaterniond q0 = Eigen::Quaterniond::UnitRandom();
    Eigen::Quaterniond q1 = Eigen::Quaterniond::UnitRandom();
    const double u = u01(rng);
    const Eigen::Quaterniond got = Slerp(q0, q1, u);
    // Slerp's formula (docs/resampling.md) on the shorter arc.
    if (q0.dot(q1) < 0) q1.coeffs() = -q1.coeffs();
    const double theta = std::acos(std::min(1.0, q0.dot(q1)));
    Eigen::Quaterniond expected;
    expected.coeffs() = std::sin((1 - u) * theta) / std::sin(theta) * q0.coeffs() +
                        std::sin(u * theta) / std::sin(theta) * q1.coeffs();
    EXPECT_LT((got.coeffs() - expected.coeffs()).norm(), 1e-12) << trial;
    EXPECT_NEAR(got.norm(), 1.0, 1e-15);
    EXPECT_LT(Angle(got, q0.slerp(u, q1)), 1e-12);
  }
}

TEST(Slerp, RobustWhenTheKeysNearlyCoincide) {
  const Eigen::Quaterniond q0(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  for (double gap : {0.0, 1e-300, 1e-15, 1e-9, 1e-5}) {
    const Eigen::Quaterniond q1 = q0 * Eigen::Quaterniond(Eigen::AngleAxisd(gap, Eigen::Vector3d::UnitX()));
    for (double u : {0.0, 0.25, 0.5, 1.0}) {
      const Eigen::Quaterniond got = Slerp(q0, q1, u);
      ASSERT_TRUE(got.coeffs().allFinite()) << gap;
      EXPECT_NEAR(got.norm(), 1.0, 1e-15);
      const Eigen::Quaterniond expected = q0 * Eigen::Quaterniond(Eigen::AngleAxisd(u * gap, Eigen::Vector3d::UnitX()));
      EXPECT_LT((got.coeffs() - expected.coeffs()).norm(), 1e-15) << gap << " " << u;
    }
  }
}

TEST(Slerp, HalfTurnGivesNoNaN) {
  const Eigen::Quaterniond q0 = Eigen::Quaterniond::Identity();
  const Eigen::Quaterniond q1(0, 0, 0, 1);  // 180° about z
  const Eigen::Quaterniond mid = Slerp(q0, q1, 0.5);
  ASSERT_TRUE(mid.coeffs().allFinite());
  EXPECT_NEAR(Angle(mid, q0), kPi / 2, 1e-12);
  EXPECT_NEAR(Angle(mid, q1), kPi / 2, 1e-12);
}

TEST(Slerp, TakesTheShortArcAndIgnoresScale) {
  const Eigen::Quaterniond q0(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()));
  const Eigen::Quaterniond q1(Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitY()));
  Eigen::Quaterniond far;
  far.coeffs() = -3.0 * q1.coeffs();
  EXPECT_LT(Angle(Slerp(q0, far, 0.5), Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()))), 1e-14);
}

TEST(RotationInterpolateJob, EveryKindPassesThroughTheKeys) {
  const Keys k = RandomKeys(9, 11, true);
  for (RotationInterpolant kind : kAllKinds) {
    const Curve c = Evaluate(k, k.times, kind);
    for (Eigen::Index i = 0; i < k.times.size(); ++i) {
      EXPECT_LT(Angle(Row(c.q, i), Eigen::Quaterniond(k.quats.row(i)(0), k.quats.row(i)(1),
                                                    k.quats.row(i)(2), k.quats.row(i)(3))),
                1e-12)
          << Name(kind) << " key " << i;
    }
  }
}

TEST(RotationInterpolateJob, UnitLengthAndSignContinuous) {
  const Keys k = RandomKeys(12, 5, true);
  const Eigen::VectorXd at = Dense(k, 3001);
  for (RotationInterpolant kind : kAllKinds) {
    const Curve c = Evaluate(k, at, kind);
    ASSERT_TRUE(c.q.allFinite()) << Name(kind);
    for (Eigen::Index j = 0; j < at.size(); ++j) {
      EXPECT_NEAR(c.q.row(j).norm(), 1.0, 1e-12) << Name(kind);
      if (j > 0) {
        EXPECT_GE(c.q.row(j).dot(c.q.row(j - 1)), 0.0) << Name(kind) << " " << j;
      }
    }
  }
}

TEST(RotationInterpolateJob, HoldsTheEndRotationsOutsideTheKeys) {
  const Keys k = RandomKeys(4, 8, false);
  Eigen::VectorXd at(4);
  at << -100.0, k.times[0], k.times[3], 1e9;
  for (RotationInterpolant kind : kAllKinds) {
    const Curve c = Evaluate(k, at, kind);
    const Eigen::Quaterniond first(k.quats(0, 0), k.quats(0, 1), k.quats(0, 2), k.quats(0, 3));
    const Eigen::Quaterniond last(k.quats(3, 0), k.quats(3, 1), k.quats(3, 2), k.quats(3, 3));
    EXPECT_LT(Angle(Row(c.q, 0), first), 1e-15);
    EXPECT_LT(Angle(Row(c.q, 1), first), 1e-14);
    EXPECT_LT(Angle(Row(c.q, 2), last), 1e-14);
    EXPECT_LT(Angle(Row(c.q, 3), last), 1e-15);
    EXPECT_EQ(c.w.row(0).norm(), 0.0);
    EXPECT_EQ(c.w.row(3).norm(), 0.0);
  }
}

TEST(RotationInterpolateJob, OneKeyIsConstant) {
  Keys k{Eigen::VectorXd::Constant(1, 2.0), RowMatrixXd(1, 4)};
  k.quats << 0, 0, 2, 0;
  Eigen::VectorXd at(3);
  at << 0, 2, 5;
  for (RotationInterpolant kind : kAllKinds) {
    const Curve c = Evaluate(k, at, kind);
    for (int j = 0; j < 3; ++j) EXPECT_EQ(c.q.row(j), Eigen::RowVector4d(0, 0, 1, 0));
  }
}

TEST(RotationInterpolateJob, AnyOrderOfEvalTimesGivesTheSameRotations) {
  const Keys k = RandomKeys(20, 2, true);
  const Eigen::VectorXd sorted = Dense(k, 500);
  Eigen::VectorXd shuffled = sorted;
  std::shuffle(shuffled.data(), shuffled.data() + shuffled.size(), std::mt19937(4));
  for (RotationInterpolant kind : kAllKinds) {
    const Curve a = Evaluate(k, sorted, kind);
    const Curve b = Evaluate(k, shuffled, kind);
    for (Eigen::Index j = 0; j < shuffled.size(); ++j) {
      const Eigen::Index i = std::find(sorted.data(), sorted.data() + sorted.size(), shuffled[j]) - sorted.data();
      EXPECT_LT(Angle(Row(a.q, i), Row(b.q, j)), 1e-15) << Name(kind);
      EXPECT_LT((a.w.row(i) - b.w.row(j)).norm(), 1e-12) << Name(kind);
    }
  }
}

// Finite-difference angular velocity, world frame: q(t+δ) q(t-δ)⁻¹ = exp(ω 2δ).
Eigen::Vector3d FiniteDifferenceOmega(const Eigen::Quaterniond& before, const Eigen::Quaterniond& after,
                                      double span) {
  const Eigen::AngleAxisd turn(after * before.conjugate());
  double angle = turn.angle();
  if (angle > kPi) angle -= 2 * kPi;
  return angle * turn.axis() / span;
}

TEST(RotationInterpolateJob, AngularVelocityMatchesFiniteDifferences) {
  const Keys k = RandomKeys(8, 21, true);
  const double delta = 1e-6;
  Eigen::VectorXd at(3 * 300);
  const Eigen::VectorXd base = Eigen::VectorXd::LinSpaced(300, k.times[0] + 0.01, k.times[7] - 0.01);
  for (int j = 0; j < 300; ++j) at.segment<3>(3 * j) << base[j] - delta, base[j], base[j] + delta;
  for (RotationInterpolant kind : kAllKinds) {
    const Curve c = Evaluate(k, at, kind);
    double worst = 0.0;
    for (int j = 0; j < 300; ++j) {
      const Eigen::Vector3d fd = FiniteDifferenceOmega(Row(c.q, 3 * j), Row(c.q, 3 * j + 2), 2 * delta);
      const Eigen::Vector3d analytic = c.w.row(3 * j + 1).transpose();
      worst = std::max(worst, (fd - analytic).norm() / std::max(1.0, analytic.norm()));
    }
    EXPECT_LT(worst, 1e-6) << Name(kind);
  }
}

// Velocity just before and just after every inner key.
double WorstVelocityJumpAtKeys(const Keys& k, RotationInterpolant kind, const KeyTcb& tcb = KeyTcb()) {
  const Eigen::Index n = k.times.size();
  Eigen::VectorXd at(2 * (n - 2));
  for (Eigen::Index i = 1; i + 1 < n; ++i) at.segment<2>(2 * (i - 1)) << k.times[i] - 1e-9, k.times[i];
  const Curve c = Evaluate(k, at, kind, tcb);
  double worst = 0.0;
  for (Eigen::Index i = 0; i + 1 < at.size(); i += 2) {
    const double jump = (c.w.row(i) - c.w.row(i + 1)).norm() / c.w.row(i + 1).norm();
    worst = std::max(worst, jump);
  }
  return worst;
}

TEST(RotationInterpolateJob, SphereSplinesAreC1AcrossKeysEvenWithUnevenSpacing) {
  for (bool uneven : {false, true}) {
    const Keys k = RandomKeys(10, 31, uneven);
    EXPECT_LT(WorstVelocityJumpAtKeys(k, RotationInterpolant::kSquad), 1e-6) << uneven;
    EXPECT_LT(WorstVelocityJumpAtKeys(k, RotationInterpolant::kCatmullRom), 1e-6) << uneven;
    Eigen::VectorXd tension = Eigen::VectorXd::LinSpaced(10, -0.5, 0.7);
    Eigen::VectorXd bias = Eigen::VectorXd::LinSpaced(10, 0.6, -0.4);
    Eigen::VectorXd continuity = Eigen::VectorXd::Zero(10);
    EXPECT_LT(WorstVelocityJumpAtKeys(k, RotationInterpolant::kKochanekBartels,
                                      KeyTcb(tension, continuity, bias)),
              1e-6)
        << uneven;
    // Piecewise slerp is only C0: the velocity jumps.
    EXPECT_GT(WorstVelocityJumpAtKeys(k, RotationInterpolant::kSlerp), 1e-2) << uneven;
  }
}

TEST(RotationInterpolateJob, ContinuityMakesCorners) {
  const Keys k = RandomKeys(6, 41, false);
  const Eigen::VectorXd none;
  const Eigen::VectorXd corner = Eigen::VectorXd::Constant(6, -1.0);
  EXPECT_GT(WorstVelocityJumpAtKeys(k, RotationInterpolant::kKochanekBartels, KeyTcb(none, corner, none)),
            1e-2);
}

TEST(RotationInterpolateJob, KochanekBartelsWithZeroParametersIsCatmullRom) {
  const Keys k = RandomKeys(9, 13, true);
  const Eigen::VectorXd at = Dense(k, 777);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(9);
  const Curve cr = Evaluate(k, at, RotationInterpolant::kCatmullRom);
  const Curve kb = Evaluate(k, at, RotationInterpolant::kKochanekBartels, KeyTcb(zero, zero, zero));
  const Curve kb_default = Evaluate(k, at, RotationInterpolant::kKochanekBartels);
  EXPECT_EQ(cr.q, kb.q);
  EXPECT_EQ(cr.w, kb.w);
  EXPECT_EQ(cr.q, kb_default.q);
}

TEST(RotationInterpolateJob, TensionOneStopsAtEveryKey) {
  const Keys k = RandomKeys(5, 17, true);
  const Eigen::VectorXd none;
  const Eigen::VectorXd one = Eigen::VectorXd::Ones(5);
  const Curve c = Evaluate(k, k.times.segment(1, 3), RotationInterpolant::kKochanekBartels, KeyTcb(one, none, none));
  EXPECT_LT(c.w.norm(), 1e-12);
}

TEST(RotationInterpolateJob, NegativeDotPairsTakeTheShortArc) {
  // Keys 40° apart about z, the second given with the opposite sign.
  Keys k{Eigen::VectorXd(3), RowMatrixXd(3, 4)};
  k.times << 0, 1, 2;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.7 * i, Eigen::Vector3d::UnitZ()));
    const double sign = i == 1 ? -1.0 : 1.0;
    k.quats.row(i) << sign * q.w(), sign * q.x(), sign * q.y(), sign * q.z();
  }
  const Eigen::VectorXd at = Eigen::VectorXd::LinSpaced(41, 0.0, 2.0);
  for (RotationInterpolant kind : kAllKinds) {
    const Curve c = Evaluate(k, at, kind);
    for (Eigen::Index j = 0; j < at.size(); ++j) {
      // On the short way the rotation stays about z within [0, 1.4] rad.
      const Eigen::Quaterniond expected(Eigen::AngleAxisd(0.7 * at[j], Eigen::Vector3d::UnitZ()));
      EXPECT_LT(Angle(Row(c.q, j), expected), 1e-12) << Name(kind) << " at " << at[j];
    }
  }
}

TEST(RotationInterpolateJob, TwoKeysReduceToSlerp) {
  Keys k{Eigen::VectorXd(2), RowMatrixXd(2, 4)};
  k.times << 1.0, 3.5;
  const Eigen::Quaterniond a = Eigen::Quaterniond::UnitRandom(), b = Eigen::Quaterniond::UnitRandom();
  k.quats << a.w(), a.x(), a.y(), a.z(), b.w(), b.x(), b.y(), b.z();
  const Eigen::VectorXd at = Eigen::VectorXd::LinSpaced(101, 1.0, 3.5);
  const Curve slerp = Evaluate(k, at, RotationInterpolant::kSlerp);
  for (RotationInterpolant kind : kSphereKinds) {
    const Curve c = Evaluate(k, at, kind);
    for (Eigen::Index j = 0; j < at.size(); ++j) {
      EXPECT_LT(Angle(Row(c.q, j), Slerp(a, b, (at[j] - 1.0) / 2.5)), 1e-13) << Name(kind);
      EXPECT_LT((c.w.row(j) - slerp.w.row(j)).norm(), 1e-12) << Name(kind);
    }
  }
}

TEST(RotationInterpolateJob, HalfTurnBetweenKeysGivesNoNaN) {
  Keys k{Eigen::VectorXd(3), RowMatrixXd(3, 4)};
  k.times << 0, 1, 2;
  k.quats << 1, 0, 0, 0,  //
      0, 1, 0, 0,         // 180° about x
      1, 0, 0, 0;
  const Eigen::VectorXd at = Eigen::VectorXd::LinSpaced(201, -0.5, 2.5);
  for (RotationInterpolant kind : kAllKinds) {
    const Curve c = Evaluate(k, at, kind);
    EXPECT_TRUE(c.q.allFinite()) << Name(kind);
    EXPECT_TRUE(c.w.allFinite()) << Name(kind);
  }
}

// The scalar Catmull-Rom of the header, written out independently.
double ScalarCatmullRom(const Eigen::VectorXd& x, const Eigen::VectorXd& y, double t) {
  const Eigen::Index n = x.size();
  Eigen::Index i = 0;
  while (i + 2 < n && t >= x[i + 1]) ++i;
  const double h = x[i + 1] - x[i], u = (t - x[i]) / h;
  const auto slope = [&](Eigen::Index k) {
    if (k == 0) return (y[1] - y[0]) / (x[1] - x[0]);
    if (k == n - 1) return (y[n - 1] - y[n - 2]) / (x[n - 1] - x[n - 2]);
    return (y[k + 1] - y[k - 1]) / (x[k + 1] - x[k - 1]);
  };
  return (2 * u * u * u - 3 * u * u + 1) * y[i] + (3 * u * u - 2 * u * u * u) * y[i + 1] +
         (u * u * u - 2 * u * u + u) * h * slope(i) + (u * u * u - u * u) * h * slope(i + 1);
}

TEST(RotationInterpolateJob, AboutOneAxisEverySplineIsTheScalarCatmullRomOfTheAngle) {
  Eigen::VectorXd times(6), angles(6);
  times << 0, 0.5, 2, 2.3, 4, 5;
  angles << 0.1, 0.9, 0.4, 1.9, 2.5, 1.0;
  Keys k{times, RowMatrixXd(6, 4)};
  for (int i = 0; i < 6; ++i) {
    const Eigen::Quaterniond q(Eigen::AngleAxisd(angles[i], Eigen::Vector3d::UnitY()));
    k.quats.row(i) << q.w(), q.x(), q.y(), q.z();
  }
  const Eigen::VectorXd at = Eigen::VectorXd::LinSpaced(400, 0.0, 5.0);
  for (RotationInterpolant kind : {RotationInterpolant::kCatmullRom,
                                   RotationInterpolant::kEulerCatmullRom,
                                   RotationInterpolant::kAxisAngleCatmullRom}) {
    const Curve c = Evaluate(k, at, kind);
    for (Eigen::Index j = 0; j + 1 < at.size(); ++j) {
      const Eigen::Quaterniond expected(Eigen::AngleAxisd(ScalarCatmullRom(times, angles, at[j]), Eigen::Vector3d::UnitY()));
      EXPECT_LT(Angle(Row(c.q, j), expected), 1e-12) << Name(kind) << " at " << at[j];
    }
  }
}

TEST(RotationInterpolateJob, EulerSplineGoesThroughTheKeysInEveryOrder) {
  const Keys k = RandomKeys(7, 3, true);
  for (EulerOrder order : {EulerOrder::kXYZ, EulerOrder::kZXY, EulerOrder::kYZX}) {
    const Curve c = Evaluate(k, k.times, RotationInterpolant::kEulerCatmullRom, KeyTcb(), order);
    for (Eigen::Index i = 0; i < 7; ++i) {
      EXPECT_LT(Angle(Row(c.q, i), Eigen::Quaterniond(k.quats(i, 0), k.quats(i, 1), k.quats(i, 2), k.quats(i, 3))), 1e-12);
    }
  }
}

TEST(RotationInterpolateJob, AxisAngleSplineCrossesTheHalfTurnSmoothly) {
  // A steady spin about z through 180°: the raw rotation vectors flip there.
  Keys k{Eigen::VectorXd::LinSpaced(8, 0.0, 7.0), RowMatrixXd(8, 4)};
  for (int i = 0; i < 8; ++i) {
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.5 * i, Eigen::Vector3d::UnitZ()));
    k.quats.row(i) << q.w(), q.x(), q.y(), q.z();
  }
  const Curve c = Evaluate(k, Eigen::VectorXd::LinSpaced(50, 0.5, 6.5), RotationInterpolant::kAxisAngleCatmullRom);
  for (Eigen::Index j = 0; j < 50; ++j) EXPECT_NEAR(c.w(j, 2), 0.5, 1e-9);
}

TEST(RotationInterpolateJob, RejectsBadInputNamingTheKey) {
  Keys k = RandomKeys(4, 1, false);
  Eigen::VectorXd at(2);
  at << 0.5, 1.0;
  RowMatrixXd out(2, 4);
  {
    Keys bad = k;
    bad.quats.row(2).setZero();
    RotationInterpolateJob job(bad.times, bad.quats, at, out);
    EXPECT_EQ(job.Validate().message(), "rotation interpolation: quaternion of key 2 (time 1.300000) is zero");
    EXPECT_THROW(job.Run(), Error);
  }
  {
    Keys bad = k;
    bad.quats(1, 3) = std::numeric_limits<double>::quiet_NaN();
    RotationInterpolateJob job(bad.times, bad.quats, at, out);
    EXPECT_EQ(job.Validate().message(), "rotation interpolation: quaternion of key 1 (time 0.800000) is not finite");
  }
  {
    Keys bad = k;
    bad.times[3] = bad.times[2];
    RotationInterpolateJob job(bad.times, bad.quats, at, out);
    EXPECT_NE(job.Validate().message().find("key 3 (1.300000) does not come after key 2"), std::string::npos);
  }
  {
    Eigen::VectorXd bad_at = at;
    bad_at[1] = std::numeric_limits<double>::infinity();
    RotationInterpolateJob job(k.times, k.quats, bad_at, out);
    EXPECT_EQ(job.Validate().message(), "rotation interpolation: eval time 1 is not finite");
  }
  {
    const Eigen::VectorXd three = Eigen::VectorXd::Zero(3), none;
    RotationInterpolateJob job(k.times, k.quats, at, out, RotationInterpolateJob::NoAngularVelocity(),
                               KeyTcb(none, three, none));
    EXPECT_EQ(job.Validate().message(),
              "rotation interpolation: continuity has 3 values for 4 keys (pass one per key, or none for 0)");
  }
  {
    RowMatrixXd small(1, 4);
    RotationInterpolateJob job(k.times, k.quats, at, small);
    EXPECT_EQ(job.Validate().message(), "rotation interpolation: out must be 2 x 4, got 1 x 4");
  }
  {
    const Eigen::VectorXd none;
    const RowMatrixXd no_quats(0, 4);
    RotationInterpolateJob job(none, no_quats, at, out);
    EXPECT_EQ(job.Validate().message(), "rotation interpolation: no keys");
  }
}

}  // namespace
}  // namespace motionkit
