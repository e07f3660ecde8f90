#include "motionkit/rotation.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <string>

namespace motionkit {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr std::array<EulerOrder, 6> kAllOrders = {EulerOrder::kXYZ, EulerOrder::kXZY,
                                                  EulerOrder::kYXZ, EulerOrder::kYZX,
                                                  EulerOrder::kZXY, EulerOrder::kZYX};

double Deg(double degrees) { return degrees * kPi / 180.0; }

// Largest entry of the difference.
double MaxDiff(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

// The documented principal ranges.
void ExpectPrincipal(const Eigen::Vector3d& a, const std::string& where) {
  EXPECT_GT(a[0], -kPi) << where;
  EXPECT_LE(a[0], kPi) << where;
  EXPECT_GE(a[1], -kPi / 2) << where;
  EXPECT_LE(a[1], kPi / 2) << where;
  EXPECT_GT(a[2], -kPi) << where;
  EXPECT_LE(a[2], kPi) << where;
}

TEST(EulerOrder, ParsesAndNamesAllSix) {
  const char* names[] = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};
  for (int o = 0; o < 6; ++o) {
    const auto parsed = ParseEulerOrder(names[o]);
    ASSERT_TRUE(parsed.has_value()) << names[o];
    EXPECT_EQ(*parsed, kAllOrders[static_cast<std::size_t>(o)]);
    EXPECT_STREQ(EulerOrderName(*parsed), names[o]);
  }
  EXPECT_FALSE(ParseEulerOrder("zxy").has_value());  // upper case only
  EXPECT_FALSE(ParseEulerOrder("XY").has_value());
  EXPECT_FALSE(ParseEulerOrder("XYZZ").has_value());
  EXPECT_FALSE(ParseEulerOrder("XXY").has_value());
  EXPECT_FALSE(ParseEulerOrder("").has_value());
}

TEST(EulerOrder, BlenderModeIsTheReversedLetters) {
  EXPECT_STREQ(BlenderEulerMode(EulerOrder::kXYZ), "ZYX");
  EXPECT_STREQ(BlenderEulerMode(EulerOrder::kXZY), "YZX");
  EXPECT_STREQ(BlenderEulerMode(EulerOrder::kYXZ), "ZXY");
  EXPECT_STREQ(BlenderEulerMode(EulerOrder::kYZX), "XZY");
  EXPECT_STREQ(BlenderEulerMode(EulerOrder::kZXY), "YXZ");
  EXPECT_STREQ(BlenderEulerMode(EulerOrder::kZYX), "XYZ");
}

TEST(EulerOrder, AxisOfEachLetter) {
  EXPECT_EQ(EulerAxis(EulerOrder::kZXY, 0), 2);
  EXPECT_EQ(EulerAxis(EulerOrder::kZXY, 1), 0);
  EXPECT_EQ(EulerAxis(EulerOrder::kZXY, 2), 1);
  for (EulerOrder order : kAllOrders) {
    const char* name = EulerOrderName(order);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(EulerAxis(order, k), name[k] - 'X') << name;
  }
}

TEST(EulerToMatrix, QuarterTurnAboutEachAxis) {
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                        z = Eigen::Vector3d::UnitZ();
  const EulerOrder o = EulerOrder::kXYZ;
  // Right-handed: X takes Y to Z, Y takes Z to X, Z takes X to Y.
  EXPECT_TRUE((EulerToMatrix({Deg(90), 0, 0}, o) * y).isApprox(z));
  EXPECT_TRUE((EulerToMatrix({Deg(90), 0, 0}, o) * z).isApprox(-y));
  EXPECT_TRUE((EulerToMatrix({0, Deg(90), 0}, o) * z).isApprox(x));
  EXPECT_TRUE((EulerToMatrix({0, Deg(90), 0}, o) * x).isApprox(-z));
  EXPECT_TRUE((EulerToMatrix({0, 0, Deg(90)}, o) * x).isApprox(y));
  EXPECT_TRUE((EulerToMatrix({0, 0, Deg(90)}, o) * y).isApprox(-x));
  // The angle goes with its letter, whatever the order.
  EXPECT_TRUE((EulerToMatrix({Deg(90), 0, 0}, EulerOrder::kZXY) * x).isApprox(y));
  EXPECT_TRUE((EulerToMatrix({0, Deg(90), 0}, EulerOrder::kZXY) * y).isApprox(z));
  EXPECT_TRUE((EulerToMatrix({0, 0, Deg(90)}, EulerOrder::kZXY) * z).isApprox(x));
}

TEST(EulerToMatrix, IntrinsicComposition) {
  // ZXY = Rz Rx Ry: the last letter acts first on a vector.
  // Rz(90) Rx(90) z: Rx takes z to -y, Rz takes -y to x.
  const Eigen::Matrix3d r = EulerToMatrix({Deg(90), Deg(90), 0}, EulerOrder::kZXY);
  EXPECT_TRUE((r * Eigen::Vector3d::UnitZ()).isApprox(Eigen::Vector3d::UnitX()));
  EXPECT_TRUE((r * Eigen::Vector3d::UnitY()).isApprox(Eigen::Vector3d::UnitZ()));
  // A worked example against explicit factors.
  const Eigen::Vector3d a(0.3, -1.1, 2.5);
  const Eigen::Matrix3d expected =
      (Eigen::AngleAxisd(a[0], Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(a[1], Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(a[2], Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  EXPECT_LT(MaxDiff(EulerToMatrix(a, EulerOrder::kZXY), expected), 1e-15);
}

TEST(EulerToQuaternion, AgreesWithMatrixForAllOrders) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-4.0, 4.0);
  for (EulerOrder order : kAllOrders) {
    for (int n = 0; n < 200; ++n) {
      const Eigen::Vector3d a(angle(rng), angle(rng), angle(rng));
      const Eigen::Quaterniond q = EulerToQuaternion(a, order);
      EXPECT_NEAR(q.norm(), 1.0, 1e-15);
      EXPECT_LT(MaxDiff(q.toRotationMatrix(), EulerToMatrix(a, order)), 1e-14)
          << EulerOrderName(order);
    }
  }
}

TEST(EulerToQuaternion, HalfAngleComponents) {
  // 90 degrees about X: (cos 45, sin 45, 0, 0); the sign follows the angles.
  const Eigen::Quaterniond q = EulerToQuaternion({Deg(90), 0, 0}, EulerOrder::kXYZ);
  EXPECT_NEAR(q.w(), std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(q.x(), std::sqrt(0.5), 1e-15);
  const Eigen::Quaterniond full_turn = EulerToQuaternion({0, 0, 2 * kPi}, EulerOrder::kXYZ);
  EXPECT_NEAR(full_turn.w(), -1.0, 1e-15);
}

TEST(MatrixToEuler, RoundTripsPrincipalAnglesForAllOrders) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> outer(-kPi + 1e-6, kPi);
  std::uniform_real_distribution<double> middle(-kPi / 2 + 1e-3, kPi / 2 - 1e-3);
  for (EulerOrder order : kAllOrders) {
    for (int n = 0; n < 500; ++n) {
      const Eigen::Vector3d a(outer(rng), middle(rng), outer(rng));
      const Eigen::Vector3d back = MatrixToEuler(EulerToMatrix(a, order), order);
      EXPECT_LT((back - a).cwiseAbs().maxCoeff(), 1e-12)
          << EulerOrderName(order) << " " << a.transpose() << " -> " << back.transpose();
      const Eigen::Vector3d from_q = QuaternionToEuler(EulerToQuaternion(a, order), order);
      EXPECT_LT((from_q - a).cwiseAbs().maxCoeff(), 1e-12) << EulerOrderName(order);
    }
  }
}

TEST(MatrixToEuler, AnyAnglesGivePrincipalAnglesOfTheSameRotation) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> angle(-10.0, 10.0);
  for (EulerOrder order : kAllOrders) {
    for (int n = 0; n < 500; ++n) {
      const Eigen::Vector3d a(angle(rng), angle(rng), angle(rng));
      const Eigen::Matrix3d r = EulerToMatrix(a, order);
      const Eigen::Vector3d e = MatrixToEuler(r, order);
      ExpectPrincipal(e, EulerOrderName(order));
      EXPECT_LT(MaxDiff(EulerToMatrix(e, order), r), 1e-13) << EulerOrderName(order);
    }
  }
}

TEST(QuaternionToEuler, IgnoresSignAndScale) {
  const Eigen::Vector3d a(0.4, -0.7, 2.9);
  for (EulerOrder order : kAllOrders) {
    const Eigen::Quaterniond q = EulerToQuaternion(a, order);
    const Eigen::Quaterniond neg(-q.w(), -q.x(), -q.y(), -q.z());
    const Eigen::Quaterniond scaled(3 * q.w(), 3 * q.x(), 3 * q.y(), 3 * q.z());
    EXPECT_LT((QuaternionToEuler(neg, order) - a).cwiseAbs().maxCoeff(), 1e-13);
    EXPECT_LT((QuaternionToEuler(scaled, order) - a).cwiseAbs().maxCoeff(), 1e-13);
  }
}

TEST(MatrixToEuler, MatchesScipyOnAFixedCase) {
  // scipy 1.17.1: Rotation.from_euler('ZYX', [0.1, 0.2, 0.3]).as_euler(order)
  const Eigen::Matrix3d r = EulerToMatrix({0.1, 0.2, 0.3}, EulerOrder::kZYX);
  struct Case {
    EulerOrder order;
    Eigen::Vector3d expected;
  };
  const Case cases[] = {
      {EulerOrder::kXYZ, {0.2857717006284608, 0.22012403121296487, 0.03787988051320079}},
      {EulerOrder::kXZY, {0.2940465670810037, 0.03696543147608411, 0.22027699150781538}},
      {EulerOrder::kYXZ, {0.22911262273937028, 0.27868939479433985, 0.10194650505404561}},
      {EulerOrder::kYZX, {0.20097742484949532, 0.09800018592316873, 0.280069217336086}},
      {EulerOrder::kZXY, {0.03862156785963429, 0.29383970051136066, 0.20908594912640976}},
      {EulerOrder::kZYX, {0.1, 0.2, 0.3}},
  };
  for (const Case& c : cases) {
    EXPECT_LT((MatrixToEuler(r, c.order) - c.expected).cwiseAbs().maxCoeff(), 1e-14)
        << EulerOrderName(c.order) << ": " << MatrixToEuler(r, c.order).transpose();
  }
}

TEST(MatrixToEuler, GimbalLockSetsTheLastAngleToZero) {
  for (EulerOrder order : kAllOrders) {
    for (double middle : {kPi / 2, -kPi / 2}) {
      const Eigen::Matrix3d r = EulerToMatrix({0.7, middle, -0.4}, order);
      const Eigen::Vector3d e = MatrixToEuler(r, order);
      EXPECT_EQ(e[2], 0.0) << EulerOrderName(order);
      EXPECT_NEAR(e[1], middle, 1e-7) << EulerOrderName(order);
      EXPECT_LT(MaxDiff(EulerToMatrix(e, order), r), 1e-14) << EulerOrderName(order);
      // Only a0 + a2 or a0 - a2 is defined there: R_j(+-pi/2) R_k(a2) equals
      // R_i(+-a2) R_j(+-pi/2) for a cyclic order (i, j, k), the opposite sign
      // for the others.
      const bool cyclic = EulerAxis(order, 1) == (EulerAxis(order, 0) + 1) % 3;
      const double combined = 0.7 + (cyclic ? 1.0 : -1.0) * (middle > 0 ? 1.0 : -1.0) * -0.4;
      EXPECT_NEAR(e[0], combined, 1e-12) << EulerOrderName(order) << " middle " << middle;
    }
  }
}

TEST(MatrixToEuler, StaysAccurateNearGimbalLock) {
  for (EulerOrder order : kAllOrders) {
    for (double gap : {1e-3, 1e-6, 1e-8, 1e-10, 1e-12, 0.0}) {
      for (double middle : {kPi / 2 - gap, -kPi / 2 + gap}) {
        const Eigen::Matrix3d r = EulerToMatrix({2.0, middle, -1.3}, order);
        const Eigen::Vector3d e = MatrixToEuler(r, order);
        ASSERT_TRUE(e.allFinite());
        ExpectPrincipal(e, EulerOrderName(order));
        EXPECT_LT(MaxDiff(EulerToMatrix(e, order), r), 1e-8)
            << EulerOrderName(order) << " gap " << gap;
      }
    }
  }
}

TEST(MatrixToEuler, HalfTurns) {
  for (EulerOrder order : kAllOrders) {
    for (const Eigen::Vector3d& a :
         {Eigen::Vector3d(kPi, 0, 0), Eigen::Vector3d(0, 0, kPi), Eigen::Vector3d(kPi, 0, kPi),
          Eigen::Vector3d(0, kPi, 0), Eigen::Vector3d(kPi, kPi, kPi)}) {
      const Eigen::Matrix3d r = EulerToMatrix(a, order);
      const Eigen::Vector3d e = MatrixToEuler(r, order);
      ExpectPrincipal(e, EulerOrderName(order));
      EXPECT_LT(MaxDiff(EulerToMatrix(e, order), r), 1e-14);
    }
  }
}

TEST(MatrixToEulerCompatible, UnwrapsPastHalfTurn) {
  // The last angle sweeps 0 .. 4 pi; the principal answer jumps at pi, the
  // compatible one keeps going.
  for (EulerOrder order : kAllOrders) {
    Eigen::Vector3d previous(0.2, 0.3, 0.0);
    for (int n = 0; n <= 400; ++n) {
      const Eigen::Vector3d a(0.2, 0.3, 4 * kPi * n / 400.0);
      const Eigen::Vector3d e = MatrixToEulerCompatible(EulerToMatrix(a, order), order, previous);
      ASSERT_LT((e - a).cwiseAbs().maxCoeff(), 1e-11)
          << EulerOrderName(order) << " step " << n << ": " << e.transpose();
      previous = e;
    }
  }
}

TEST(MatrixToEulerCompatible, ContinuousThroughPastTheMiddleRange) {
  // The middle angle goes past pi/2, where only the alternate solution
  // (a0 + pi, pi - a1, a2 + pi) continues the curve.
  for (EulerOrder order : kAllOrders) {
    Eigen::Vector3d previous(0.3, 0.0, -0.2);
    for (int n = 0; n <= 300; ++n) {
      const Eigen::Vector3d a(0.3 + 0.01 * n, 0.0101 * n, -0.2 - 0.02 * n);
      const Eigen::Vector3d e = MatrixToEulerCompatible(EulerToMatrix(a, order), order, previous);
      ASSERT_LT((e - a).cwiseAbs().maxCoeff(), 1e-9)
          << EulerOrderName(order) << " step " << n << ": " << e.transpose() << " vs "
          << a.transpose();
      previous = e;
    }
  }
}

TEST(MatrixToEulerCompatible, RandomSmoothPathHasSmallSteps) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> gauss;
  const auto random_quaternion = [&] {
    return Eigen::Quaterniond(gauss(rng), gauss(rng), gauss(rng), gauss(rng)).normalized();
  };
  for (EulerOrder order : kAllOrders) {
    // A smooth path in rotation space (quaternion interpolation between random
    // keys), converted frame by frame.
    Eigen::Quaterniond key = random_quaternion();
    Eigen::Vector3d previous = MatrixToEuler(key.toRotationMatrix(), order);
    for (int segment = 0; segment < 20; ++segment) {
      const Eigen::Quaterniond next = random_quaternion();
      for (int n = 1; n <= 50; ++n) {
        const Eigen::Quaterniond q = key.slerp(n / 50.0, next);
        const Eigen::Matrix3d r = q.toRotationMatrix();
        const Eigen::Vector3d e = MatrixToEulerCompatible(r, order, previous);
        EXPECT_LT(MaxDiff(EulerToMatrix(e, order), r), 1e-12);
        EXPECT_LT((e - previous).cwiseAbs().maxCoeff(), kPi) << EulerOrderName(order);
        previous = e;
      }
      key = next;
    }
  }
}

TEST(MatrixToEulerCompatible, GimbalLockKeepsTheLastAngle) {
  for (EulerOrder order : kAllOrders) {
    for (double middle : {kPi / 2, -kPi / 2}) {
      // Along a curve that sits in the lock, only a0 +- a2 is known; the last
      // angle stays where it was and the first takes the rest.
      Eigen::Vector3d previous(0.1, middle * 0.99, 0.2);
      for (int n = 0; n < 100; ++n) {
        const Eigen::Matrix3d r = EulerToMatrix({0.1 + 0.05 * n, middle, 0.2 - 0.03 * n}, order);
        const Eigen::Vector3d e = MatrixToEulerCompatible(r, order, previous);
        ASSERT_LT(MaxDiff(EulerToMatrix(e, order), r), 1e-13) << EulerOrderName(order);
        EXPECT_EQ(e[2], 0.2) << EulerOrderName(order);
        EXPECT_LT((e - previous).cwiseAbs().maxCoeff(), 0.2) << EulerOrderName(order) << " " << n;
        previous = e;
      }
    }
  }
}

// Each of these agrees with Blender 5.2.2 and 3.4 (Matrix.to_euler(mode,
// compat) with mode = BlenderEulerMode(order), angles by axis) to single
// precision.
TEST(MatrixToEulerCompatible, WorkedExamples) {
  const EulerOrder order = EulerOrder::kXYZ;
  // One whole turn: principal last angle -3.0, previous 3.0 -> 2 pi - 3.0.
  {
    const Eigen::Matrix3d r = EulerToMatrix({0.0, 0.0, -3.0}, order);
    const Eigen::Vector3d e = MatrixToEulerCompatible(r, order, {0.0, 0.0, 3.0});
    EXPECT_LT((e - Eigen::Vector3d(0.0, 0.0, 2 * kPi - 3.0)).cwiseAbs().maxCoeff(), 1e-14);
  }
  // Several turns away: each axis to within pi of its previous value.
  {
    const Eigen::Matrix3d r = EulerToMatrix({0.5, 0.1, -0.5}, order);
    const Eigen::Vector3d previous(0.4 + 6 * kPi, 0.0, -0.4 - 4 * kPi);
    const Eigen::Vector3d e = MatrixToEulerCompatible(r, order, previous);
    EXPECT_LT((e - Eigen::Vector3d(0.5 + 6 * kPi, 0.1, -0.5 - 4 * kPi)).cwiseAbs().maxCoeff(),
              1e-12);
  }
  // The alternate solution wins: principal (0.1, 0.2, -0.1), alternate
  // (0.1 + pi, pi - 0.2, pi - 0.1); previous (pi, pi - 0.15, pi).
  //   principal: |0.1 - pi| + |0.2 - (pi - 0.15)| + |-0.1 - pi| = 3.04 + 2.79 + 3.24
  //   alternate: 0.1 + 0.05 + 0.1 = 0.25
  {
    const Eigen::Matrix3d r = EulerToMatrix({0.1, 0.2, -0.1}, order);
    const Eigen::Vector3d e = MatrixToEulerCompatible(r, order, {kPi, kPi - 0.15, kPi});
    EXPECT_LT((e - Eigen::Vector3d(0.1 + kPi, kPi - 0.2, kPi - 0.1)).cwiseAbs().maxCoeff(), 1e-13)
        << e.transpose();
  }
  // ZXY (Blender 'YXZ'): a middle angle past pi/2 and a first angle past pi,
  // followed from a previous value near both.
  {
    const Eigen::Matrix3d r = EulerToMatrix({3.1, 2.9, -1.2}, EulerOrder::kZXY);
    const Eigen::Vector3d e = MatrixToEulerCompatible(r, EulerOrder::kZXY, {-3.0, 2.5, -1.0});
    EXPECT_LT((e - Eigen::Vector3d(3.1 - 2 * kPi, 2.9, -1.2)).cwiseAbs().maxCoeff(), 1e-13)
        << e.transpose();
  }
  // The same rotation from previous zero: the principal solution.
  {
    const Eigen::Matrix3d r = EulerToMatrix({0.1, 0.2, -0.1}, order);
    const Eigen::Vector3d e = MatrixToEulerCompatible(r, order, Eigen::Vector3d::Zero());
    EXPECT_LT((e - Eigen::Vector3d(0.1, 0.2, -0.1)).cwiseAbs().maxCoeff(), 1e-14);
  }
}

}  // namespace
}  // namespace motionkit

namespace motionkit {
namespace {

// Quaternion channels: each bone's rows the input's components, on one hemisphere from row to row (the
// first on previous' side), whatever the number of threads; bad quaternions refused, naming them.
TEST(QuaternionChannels, KeepEachBoneOnOneHemisphereAsCurvesTakeThem) {
  const int rows = 300, bones = 3;
  std::mt19937 rng(3);
  std::normal_distribution<double> step(0.0, 0.3);
  RowMatrixXd q(rows, 4 * bones);
  for (int c = 0; c < bones; ++c) {
    Eigen::Quaterniond at = Eigen::Quaterniond::Identity();
    for (int i = 0; i < rows; ++i) {
      at = at * Eigen::Quaterniond(Eigen::AngleAxisd(std::abs(step(rng)), Eigen::Vector3d(step(rng), 1, step(rng)).normalized()));
      const double sign = (rng() % 3 == 0) ? -1.0 : 1.0;  // flipped at random: the same rotation
      q.row(i).segment<4>(4 * c) << sign * at.w(), sign * at.x(), sign * at.y(), sign * at.z();
    }
  }
  Eigen::VectorXd previous(4 * bones);
  previous << -1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0;
  RowMatrixXd one(4 * bones, rows), many(4 * bones, rows);
  ASSERT_TRUE(QuaternionChannels(q, previous, one, 1).ok());
  ASSERT_TRUE(QuaternionChannels(q, previous, many, 3).ok());
  EXPECT_EQ(one, many);
  for (int c = 0; c < bones; ++c) {
    Eigen::Vector4d last = previous.segment<4>(4 * c);
    for (int i = 0; i < rows; ++i) {
      const Eigen::Vector4d in = q.row(i).segment<4>(4 * c).transpose();
      const Eigen::Vector4d out = one.block<4, 1>(4 * c, i);
      EXPECT_TRUE(out == in || out == -in) << "bone " << c << " row " << i;
      EXPECT_GE(out.dot(last), 0.0) << "bone " << c << " row " << i;
      last = out;
    }
  }
  q(7, 4) = q(7, 5) = q(7, 6) = q(7, 7) = 0.0;
  const Status bad = QuaternionChannels(q, previous, one);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("quaternion 7 of bone 1"), std::string::npos) << bad.message();
  EXPECT_FALSE(QuaternionChannels(q, Eigen::VectorXd::Zero(8), one).ok());
}

}  // namespace
}  // namespace motionkit
