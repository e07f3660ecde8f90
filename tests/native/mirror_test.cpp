#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "motionkit/mirror.hpp"
#include "motionkit/rig.hpp"
#include "random_poses.hpp"
#include "rig_specs.hpp"

namespace motionkit {
namespace {

using test_rigs::BoneSpec;
using test_rigs::MakeRig;
using test_rigs::RandomPoses;

constexpr double kPi = 3.14159265358979323846;

// A small body, symmetric about X = 0 in its heads and tails but not in its rolls (each bone its own
// random roll), with a prop under the right hand that has no partner.
std::vector<BoneSpec> Body(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> any(-kPi, kPi);
  std::vector<BoneSpec> b{{"hips", -1, {0, 0, 1.0}, {0, 0, 1.1}, any(rng)},
                          {"spine", 0, {0, 0, 1.1}, {0, 0.02, 1.5}, any(rng)},
                          {"head", 1, {0, 0.02, 1.5}, {0, 0.02, 1.7}, any(rng)}};
  for (const double side : {1.0, -1.0}) {
    const std::string s = side > 0 ? ".L" : ".R";
    const int arm = static_cast<int>(b.size());
    b.push_back({"upper_arm" + s, 1, {side * 0.2, 0, 1.45}, {side * 0.45, 0.03, 1.3}, any(rng)});
    b.push_back({"hand" + s, arm, {side * 0.45, 0.03, 1.3}, {side * 0.6, 0.05, 1.2}, any(rng)});
    const int thigh = static_cast<int>(b.size());
    b.push_back({"thigh" + s, 0, {side * 0.1, 0, 1.0}, {side * 0.11, -0.02, 0.55}, any(rng)});
    b.push_back({"shin" + s, thigh, {side * 0.11, -0.02, 0.55}, {side * 0.1, 0, 0.1}, any(rng)});
  }
  b.push_back({"prop", 8, {-0.6, 0.05, 1.2}, {-0.6, 0.3, 1.2}, any(rng)});  // under hand.R
  return b;
}

int Partner(const RigModel& rig, int b) {
  std::string n = rig.name(b);
  if (n.size() > 2 && n[n.size() - 2] == '.') n.back() = n.back() == 'L' ? 'R' : 'L';
  return n == "prop" ? -1 : rig.Find(n);
}

struct Clip {
  RowMatrixXd rotations, locations;
};

Clip RandomClip(const RigModel& rig, int frames, unsigned seed) {
  Clip clip{RandomPoses(rig.size(), frames, seed), RowMatrixXd::Zero(frames, 3 * rig.size())};
  for (int f = 0; f < frames; ++f) clip.locations.row(f).head<3>() << 0.1 * f, -0.05 * f, 0.02 * std::sin(f);
  return clip;
}

struct Posed {
  RowMatrixXd rotations, heads;
};

Posed Pose(const RigModel& rig, const Clip& clip) {
  Posed p{RowMatrixXd(clip.rotations.rows(), 4 * rig.size()), RowMatrixXd(clip.rotations.rows(), 3 * rig.size())};
  ArmaturePoseJob job(rig, clip.rotations, clip.locations, p.rotations, p.heads);
  job.Run();
  return p;
}

struct Pairing {
  std::vector<int> partners, kept;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
};

Pairing ByName(const RigModel& source, const RigModel& target) {
  Pairing setup;
  for (int b = 0; b < target.size(); ++b) {
    const int own = source.Find(target.name(b));
    const int partner = Partner(target, b);
    setup.partners.push_back(partner < 0 ? -1 : source.Find(target.name(partner)));
    setup.kept.push_back(partner < 0 ? own : -1);
  }
  return setup;
}

Clip Mirror(const RigModel& source, const RigModel& target, const Clip& clip, const Pairing& setup) {
  const Posed posed = Pose(source, clip);
  const Eigen::Index frames = clip.rotations.rows();
  Clip out{RowMatrixXd(frames, 4 * target.size()), RowMatrixXd(frames, 3 * target.size())};
  MirrorJob job(source, target, posed.rotations, posed.heads, out.rotations, out.locations);
  job.partners = setup.partners;
  job.kept = setup.kept;
  job.normal = setup.normal;
  job.point = setup.point;
  job.Run();
  return out;
}

Eigen::Vector3d Reflect(const Eigen::Vector3d& h, const Pairing& s) {
  const Eigen::Vector3d n = s.normal.normalized();
  return h - 2.0 * (h - s.point).dot(n) * n;
}

Eigen::Matrix3d Reflection(const Pairing& s) {
  const Eigen::Vector3d n = s.normal.normalized();
  return Eigen::Matrix3d::Identity() - 2.0 * n * n.transpose();
}

TEST(Mirror, TwiceGivesTheClipBack) {
  const RigModel rig = MakeRig(Body(3));
  const Clip clip = RandomClip(rig, 12, 5);
  Pairing setup = ByName(rig, rig);
  setup.normal = Eigen::Vector3d(1, 0.2, -0.1);  // any plane: twice across it is the identity
  setup.point = Eigen::Vector3d(0.3, -0.1, 0.05);
  const Clip back = Mirror(rig, rig, Mirror(rig, rig, clip, setup), setup);
  for (int f = 0; f < 12; ++f) {
    for (int b = 0; b < rig.size(); ++b) {
      EXPECT_LT(QuatAt(back.rotations, f, b).angularDistance(QuatAt(clip.rotations, f, b).normalized()), 1e-9)
          << rig.name(b) << " frame " << f;
      EXPECT_LT((back.locations.row(f).segment<3>(3 * b) - clip.locations.row(f).segment<3>(3 * b)).norm(), 1e-9)
          << rig.name(b) << " frame " << f;
    }
  }
}

// Heads land on the reflections of their partners' heads, and each bone turns from its own rest as the
// partner turned from its rest, reflected: R'_b Rest_b^-1 = L (R_p Rest_p^-1) L, as matrices.
TEST(Mirror, ReflectsWorldPositionsAndTurnsWhateverTheRolls) {
  const RigModel rig = MakeRig(Body(7));
  const Clip clip = RandomClip(rig, 8, 11);
  const Pairing setup = ByName(rig, rig);
  const Posed before = Pose(rig, clip);
  const Posed after = Pose(rig, Mirror(rig, rig, clip, setup));
  const Eigen::Matrix3d L = Reflection(setup);
  for (int f = 0; f < 8; ++f) {
    for (int b = 0; b < rig.size(); ++b) {
      const int p = setup.partners[static_cast<std::size_t>(b)];
      if (p < 0) continue;
      const Eigen::Vector3d expected = Reflect(before.heads.row(f).segment<3>(3 * p).transpose(), setup);
      EXPECT_LT((after.heads.row(f).segment<3>(3 * b).transpose() - expected).norm(), 1e-9) << rig.name(b);
      const Eigen::Matrix3d turn = (QuatAt(before.rotations, f, p) * rig.rest(p).conjugate()).toRotationMatrix();
      const Eigen::Matrix3d mirrored = (QuatAt(after.rotations, f, b) * rig.rest(b).conjugate()).toRotationMatrix();
      EXPECT_LT((mirrored - L * turn * L).norm(), 1e-9) << rig.name(b) << " frame " << f;
    }
  }
}

TEST(Mirror, RootMotionIsMirrored) {
  const RigModel rig = MakeRig(Body(1));
  Clip clip{RowMatrixXd::Zero(3, 4 * rig.size()), RowMatrixXd::Zero(3, 3 * rig.size())};
  for (int b = 0; b < rig.size(); ++b) clip.rotations.col(4 * b).setOnes();
  for (int f = 0; f < 3; ++f) {  // the hips move 0.5 per frame along armature +X
    clip.locations.row(f).head<3>() = (rig.rest(0).conjugate() * Eigen::Vector3d(0.5 * f, 0, 0)).transpose();
  }
  const Posed posed = Pose(rig, clip);
  const Posed mirrored = Pose(rig, Mirror(rig, rig, clip, ByName(rig, rig)));
  for (int f = 0; f < 3; ++f) {
    EXPECT_NEAR(posed.heads(f, 0), 0.5 * f, 1e-12);
    EXPECT_NEAR(mirrored.heads(f, 0), -posed.heads(f, 0), 1e-12);
    EXPECT_NEAR(mirrored.heads(f, 1), posed.heads(f, 1), 1e-12);
    EXPECT_NEAR(mirrored.heads(f, 2), posed.heads(f, 2), 1e-12);
  }
}

TEST(Mirror, ABoneWithoutPartnerKeepsItsLocalTransform) {
  const RigModel rig = MakeRig(Body(2));
  const Clip clip = RandomClip(rig, 4, 9);
  const Clip out = Mirror(rig, rig, clip, ByName(rig, rig));
  const int prop = rig.Find("prop");
  for (int f = 0; f < 4; ++f) {
    EXPECT_LT(QuatAt(out.rotations, f, prop).angularDistance(QuatAt(clip.rotations, f, prop).normalized()), 1e-12);
    EXPECT_LT((out.locations.row(f).segment<3>(3 * prop) - clip.locations.row(f).segment<3>(3 * prop)).norm(), 1e-12);
  }
}

TEST(Mirror, OntoAnotherRigWithOtherRolls) {
  const RigModel source = MakeRig(Body(4));
  const RigModel target = MakeRig(Body(8));  // same heads, other rolls
  const Clip clip = RandomClip(source, 6, 2);
  const Pairing setup = ByName(source, target);
  const Posed before = Pose(source, clip);
  const Posed after = Pose(target, Mirror(source, target, clip, setup));
  for (int f = 0; f < 6; ++f) {
    for (int b = 0; b < target.size(); ++b) {
      const int p = setup.partners[static_cast<std::size_t>(b)];
      if (p < 0) continue;
      const Eigen::Vector3d expected = Reflect(before.heads.row(f).segment<3>(3 * p).transpose(), setup);
      EXPECT_LT((after.heads.row(f).segment<3>(3 * b).transpose() - expected).norm(), 1e-9) << target.name(b);
    }
  }
}

TEST(Mirror, RotationsAreContinuousFromFrameToFrame) {
  const RigModel rig = MakeRig(Body(5));
  Clip clip = RandomClip(rig, 30, 4);
  for (int f = 1; f < 30; ++f) {  // a slow turn: neighbours close, so a sign flip would show
    clip.rotations.row(f) = 0.9 * clip.rotations.row(f - 1) + 0.1 * clip.rotations.row(f);
  }
  const Clip out = Mirror(rig, rig, clip, ByName(rig, rig));
  for (int f = 1; f < 30; ++f) {
    for (int b = 0; b < rig.size(); ++b) {
      EXPECT_GE(out.rotations.row(f).segment<4>(4 * b).dot(out.rotations.row(f - 1).segment<4>(4 * b)), 0.0);
    }
  }
}

TEST(Mirror, RefusesBadInputNamingWhatIsWrong) {
  const RigModel rig = MakeRig(Body(6));
  Clip clip = RandomClip(rig, 3, 1);
  const Posed posed = Pose(rig, clip);
  RowMatrixXd rotations(3, 4 * rig.size()), locations(3, 3 * rig.size());
  const Pairing good = ByName(rig, rig);
  const auto message = [&](auto change, RowMatrixXd source_rotations) {
    MirrorJob job(rig, rig, source_rotations, posed.heads, rotations, locations);
    job.partners = good.partners;
    job.kept = good.kept;
    change(job);
    const Status status = job.Validate();
    EXPECT_FALSE(status.ok());
    EXPECT_THROW(job.Run(), Error);
    return status.message();
  };
  EXPECT_NE(message([](MirrorJob& j) { j.partners.pop_back(); }, posed.rotations).find("one entry per target bone"),
            std::string::npos);
  EXPECT_NE(message([](MirrorJob& j) { j.kept[2] = 99; }, posed.rotations).find("'head'"), std::string::npos);
  EXPECT_NE(message([](MirrorJob& j) { j.normal.setZero(); }, posed.rotations).find("normal"), std::string::npos);
  RowMatrixXd broken = posed.rotations;
  broken(2, 4 * 3) = std::nan("");
  const std::string bad = message([](MirrorJob&) {}, broken);
  EXPECT_NE(bad.find("'upper_arm.L'"), std::string::npos) << bad;
  EXPECT_NE(bad.find("frame index 2"), std::string::npos) << bad;
}

}  // namespace
}  // namespace motionkit
