#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "motionkit/retarget.hpp"
#include "motionkit/rig.hpp"
#include "random_poses.hpp"
#include "rig_specs.hpp"

namespace motionkit {
namespace {

using test_rigs::BoneSpec;
using test_rigs::MakeRig;
using test_rigs::RandomPoses;

constexpr double kPi = 3.14159265358979323846;

// Rest orientation as Blender makes it from head, tail and roll (the shortest
// A small humanoid: hips, a spine of `spine` bones, a left arm whose rest
// points `arm_down` radians below horizontal, a left leg. Optional extra roll
// on every bone.
std::vector<BoneSpec> Humanoid(int spine, double arm_down, double roll_seed = 0.0, double size = 1.0) {
  std::mt19937 rng(static_cast<unsigned>(roll_seed * 1000));
  std::uniform_real_distribution<double> any(-kPi, kPi);
  const auto roll = [&]() { return roll_seed != 0.0 ? any(rng) : 0.0; };
  std::vector<BoneSpec> b;
  const double s = size;
  b.push_back({"hips", -1, {0, 0, 1.0 * s}, {0, 0, 1.1 * s}, roll()});
  double z = 1.1 * s;
  int parent = 0;
  for (int i = 0; i < spine; ++i) {
    const double step = 0.45 * s / spine;
    b.push_back({"spine" + std::to_string(i), parent, {0, 0, z}, {0, 0, z + step}, roll()});
    parent = static_cast<int>(b.size()) - 1;
    z += step;
  }
  const int chest = parent;
  const Eigen::Vector3d shoulder(0.2 * s, 0, z - 0.05 * s);
  const Eigen::Vector3d dir(std::cos(arm_down), 0, -std::sin(arm_down));
  b.push_back({"clavicle", chest, {0.02 * s, 0, z - 0.05 * s}, shoulder, roll()});
  const int clavicle = static_cast<int>(b.size()) - 1;
  b.push_back({"upper_arm", clavicle, shoulder, shoulder + 0.3 * s * dir, roll()});
  b.push_back({"forearm", clavicle + 1, shoulder + 0.3 * s * dir, shoulder + 0.56 * s * dir, roll()});
  b.push_back({"thigh", 0, {0.1 * s, 0, 1.0 * s}, {0.1 * s, -0.01 * s, 0.54 * s}, roll()});
  const int thigh = static_cast<int>(b.size()) - 1;
  b.push_back({"shin", thigh, {0.1 * s, -0.01 * s, 0.54 * s}, {0.1 * s, 0, 0.1 * s}, roll()});
  b.push_back({"foot", thigh + 1, {0.1 * s, 0, 0.1 * s}, {0.1 * s, -0.14 * s, 0.02 * s}, roll()});
  return b;
}

struct Posed {
  RowMatrixXd rotations, heads;
};

Posed Pose(const RigModel& rig, const RowMatrixXd& basis, const RowMatrixXd& locations) {
  Posed p{RowMatrixXd(basis.rows(), 4 * rig.size()), RowMatrixXd(basis.rows(), 3 * rig.size())};
  ArmaturePoseJob job(rig, basis, locations, p.rotations, p.heads);
  job.Run();
  return p;
}

Eigen::Vector3d Direction(const RowMatrixXd& rotations, Eigen::Index f, int b) {
  return QuatAt(rotations, f, b) * Eigen::Vector3d::UnitY();
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / kPi;
}

// Retargets every frame with the map by name, match poses at rest.
struct Retargeted {
  RowMatrixXd rotations, roots;
};

Retargeted Retarget(const RigModel& source, const RigModel& target, const Posed& posed, RetargetOptions options = {},
             std::vector<int> map = {}, const RowMatrixXd& target_aims = RowMatrixXd()) {
  const Eigen::Index frames = posed.rotations.rows();
  Retargeted out{RowMatrixXd(frames, 4 * target.size()), RowMatrixXd(frames, 3)};
  RowMatrixXd source_match(1, 4 * source.size()), target_match(1, 4 * target.size());
  for (int a = 0; a < source.size(); ++a) {
    const Eigen::Quaterniond q = source.rest(a);
    source_match.row(0).segment<4>(4 * a) << q.w(), q.x(), q.y(), q.z();
  }
  for (int b = 0; b < target.size(); ++b) target_match.row(0).segment<4>(4 * b) << 1, 0, 0, 0;
  RowMatrixXd root_heads = posed.heads.leftCols(3);
  RetargetJob job(source, target, posed.rotations, root_heads, source_match, target_match, out.rotations,
                  out.roots);
  if (map.empty()) {
    for (int b = 0; b < target.size(); ++b) map.push_back(source.Find(target.name(b)));
  }
  job.bone_map = map;
  job.source_match_root = source.head(0);
  job.source_root = 0;
  job.target_root = 0;
  job.target_aims = target_aims;
  job.options = options;
  job.Run();
  return out;
}

TEST(ArmaturePose, MatchesAHandDerivedChain) {
  // Root along +Y at the origin, child along +Y above it; root turned 90 deg about Z.
  const RigModel rig = MakeRig({{"a", -1, {0, 0, 0}, {0, 1, 0}, 0}, {"b", 0, {0, 1, 0}, {0, 2, 0}, 0}});
  RowMatrixXd basis(1, 8), locations(1, 6);
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()));
  basis << turn.w(), turn.x(), turn.y(), turn.z(), 1, 0, 0, 0;
  locations << 0, 0, 0.5, 0, 0, 0;  // the root moved 0.5 along its own Z (= world Z)
  const Posed p = Pose(rig, basis, locations);
  EXPECT_NEAR((p.heads.row(0).transpose() - Eigen::Vector3d(0, 0, 0.5)).norm(), 0, 1e-12);
  EXPECT_NEAR((p.heads.row(0).segment<3>(3).transpose() - Eigen::Vector3d(-1, 0, 0.5)).norm(), 0, 1e-12);
  EXPECT_NEAR((Direction(p.rotations, 0, 1) - Eigen::Vector3d(-1, 0, 0)).norm(), 0, 1e-12);
}

TEST(Retarget, SameRigGivesTheSamePose) {
  const RigModel rig = MakeRig(Humanoid(3, 0.0));
  RowMatrixXd basis = RandomPoses(rig.size(), 20, 1);
  RowMatrixXd locations = RowMatrixXd::Zero(20, 3 * rig.size());
  for (int f = 0; f < 20; ++f) locations.row(f).head<3>() << 0.1 * f, -0.05 * f, 0.02 * std::sin(f);
  const Posed posed = Pose(rig, basis, locations);
  const Retargeted run = Retarget(rig, rig, posed);
  for (int f = 0; f < 20; ++f) {
    for (int b = 0; b < rig.size(); ++b) {
      // The angle between the two rotations (q and -q alike), not |q1 . q2| ~ 1, which hides 1e-6 rad.
      const double angle = QuatAt(run.rotations, f, b).normalized().angularDistance(QuatAt(basis, f, b).normalized());
      EXPECT_LT(angle, 1e-9) << rig.name(b) << " frame " << f;
    }
    EXPECT_NEAR((run.roots.row(f) - locations.row(f).head<3>()).norm(), 0, 1e-12);
  }
}

// The lab check (docs/retargeting.md): a T-pose and an A-pose rig with the same bones
// pose the same world joints on every frame, both ways; rolls on the target
// change nothing.
TEST(Retarget, TPoseToAPoseAndBackKeepsEveryJoint) {
  for (const double roll_seed : {0.0, 0.37}) {
    const RigModel t_rig = MakeRig(Humanoid(3, 0.0));
    const RigModel a_rig = MakeRig(Humanoid(3, kPi / 4, roll_seed));
    for (const bool forward : {true, false}) {
      const RigModel& source = forward ? t_rig : a_rig;
      const RigModel& target = forward ? a_rig : t_rig;
      const RowMatrixXd basis = RandomPoses(source.size(), 30, 7);
      const RowMatrixXd no_locations = RowMatrixXd::Zero(30, 3 * source.size());
      const Posed posed = Pose(source, basis, no_locations);
      const Retargeted run = Retarget(source, target, posed);
      RowMatrixXd target_locations = RowMatrixXd::Zero(30, 3 * target.size());
      target_locations.leftCols(3) = run.roots;
      const Posed result = Pose(target, run.rotations, target_locations);
      for (int f = 0; f < 30; ++f) {
        for (int b = 0; b < target.size(); ++b) {
          const int a = source.Find(target.name(b));
          EXPECT_LT(AngleDeg(Direction(result.rotations, f, b), Direction(posed.rotations, f, a)), 1e-9)
              << target.name(b) << " frame " << f;
          const Eigen::Vector3d tail_t = result.heads.row(f).segment<3>(3 * b).transpose() +
                                         target.length(b) * Direction(result.rotations, f, b);
          const Eigen::Vector3d tail_s = posed.heads.row(f).segment<3>(3 * a).transpose() +
                                         source.length(a) * Direction(posed.rotations, f, a);
          EXPECT_LT((tail_t - tail_s).norm(), 1e-9) << target.name(b) << " frame " << f;
        }
      }
    }
  }
}

// A hand whose fingers spread across Z on the source and across Y on the target (the palm turned a
// quarter about the arm in one rest pose): the target's palm faces as the source's on every frame.
TEST(Retarget, AHandTurnsAboutItsLineToLayItsFingersAsTheSources) {
  const auto hand = [](const Eigen::Vector3d& across) {
    const Eigen::Vector3d tip(0.4, 0, 0), along(0.05, 0, 0);
    return std::vector<BoneSpec>{{"arm", -1, {0, 0, 0}, {0.3, 0, 0}, 0.0},
                                 {"hand", 0, {0.3, 0, 0}, tip, 0.0},
                                 {"index", 1, tip + across, tip + across + along, 0.0},
                                 {"middle", 1, tip, tip + along, 0.0},
                                 {"pinky", 1, tip - across, tip - across + along, 0.0}};
  };
  const RigModel source = MakeRig(hand({0, 0, 0.03}));
  const RigModel target = MakeRig(hand({0, 0.03, 0}));
  const RowMatrixXd basis = RandomPoses(source.size(), 20, 11);
  const Posed posed = Pose(source, basis, RowMatrixXd::Zero(20, 3 * source.size()));
  const Retargeted run = Retarget(source, target, posed);
  RowMatrixXd locations = RowMatrixXd::Zero(20, 3 * target.size());
  locations.leftCols(3) = run.roots;
  const Posed result = Pose(target, run.rotations, locations);
  for (int f = 0; f < 20; ++f) {
    for (const int finger : {2, 4}) {
      const Eigen::Vector3d want = posed.heads.row(f).segment<3>(3 * finger) - posed.heads.row(f).segment<3>(3);
      const Eigen::Vector3d got = result.heads.row(f).segment<3>(3 * finger) - result.heads.row(f).segment<3>(3);
      EXPECT_LT((got - want).norm(), 1e-9) << target.name(finger) << " frame " << f;
    }
  }
}

TEST(Retarget, ChainsOfOtherLengthsEndAsTheSourceAndBendBetween) {
  const RigModel source = MakeRig(Humanoid(3, 0.0));
  for (const int spine : {2, 5}) {
    const RigModel target = MakeRig(Humanoid(spine, 0.0));
    const RowMatrixXd basis = RandomPoses(source.size(), 10, 3, 0.3);
    const Posed posed = Pose(source, basis, RowMatrixXd::Zero(10, 3 * source.size()));
    // Map everything by name except the spine: only the chest (last spine bone).
    std::vector<int> map;
    for (int b = 0; b < target.size(); ++b) {
      const std::string& n = target.name(b);
      map.push_back(n.rfind("spine", 0) == 0 ? -1 : source.Find(n));
    }
    const int target_chest = target.Find("spine" + std::to_string(spine - 1));
    map[static_cast<std::size_t>(target_chest)] = source.Find("spine2");
    const Retargeted run = Retarget(source, target, posed, {}, map);
    const Posed result = Pose(target, run.rotations, RowMatrixXd::Zero(10, 3 * target.size()));
    for (int f = 0; f < 10; ++f) {
      EXPECT_LT(AngleDeg(Direction(result.rotations, f, target_chest), Direction(posed.rotations, f, 3)), 1e-9);
      // Every interior bone lies on the source chain: on the shortest arc
      // between two consecutive orientations of hips, spine0, spine1, spine2
      // (all these bones share one rest orientation).
      for (int i = 0; i + 1 < spine; ++i) {
        const Eigen::Quaterniond g = QuatAt(result.rotations, f, target.Find("spine" + std::to_string(i)));
        double best = 1e9;
        for (int k = 0; k < 3; ++k) {
          const Eigen::Quaterniond lo = QuatAt(posed.rotations, f, k), hi = QuatAt(posed.rotations, f, k + 1);
          best = std::min(best, g.angularDistance(lo) + g.angularDistance(hi) - lo.angularDistance(hi));
        }
        EXPECT_LT(best, 1e-9) << "spine" << i << " of " << spine << ", frame " << f;
      }
    }
  }
}

// Retargets like Retarget() and returns the job's kept_posture too.
std::vector<int> KeptPosture(const RigModel& source, const RigModel& target, const Posed& posed,
                             const RetargetOptions& options, RowMatrixXd* rotations) {
  const Eigen::Index frames = posed.rotations.rows();
  RowMatrixXd roots(frames, 3), source_match(1, 4 * source.size()), target_match(1, 4 * target.size());
  rotations->resize(frames, 4 * target.size());
  for (int a = 0; a < source.size(); ++a) {
    const Eigen::Quaterniond q = source.rest(a);
    source_match.row(0).segment<4>(4 * a) << q.w(), q.x(), q.y(), q.z();
  }
  for (int b = 0; b < target.size(); ++b) target_match.row(0).segment<4>(4 * b) << 1, 0, 0, 0;
  const RowMatrixXd root_heads = posed.heads.leftCols(3);
  RetargetJob job(source, target, posed.rotations, root_heads, source_match, target_match, *rotations, roots);
  for (int b = 0; b < target.size(); ++b) job.bone_map.push_back(source.Find(target.name(b)));
  job.source_match_root = source.head(0);
  job.source_root = job.target_root = 0;
  job.options = options;
  job.Run();
  return job.kept_posture;
}

// A target arm resting 15 degrees below the source's T keeps its posture where asked: it moves from its own
// rest as the source's arm moves from its own, so it stays 15 degrees off the source's on every frame and
// turns from rest exactly as the source's does; not kept, it points as the source's.
TEST(Retarget, APostureBoneMovesFromItsOwnRestAsTheSourceFromIts) {
  const RigModel source = MakeRig(Humanoid(3, 0.0));
  const RigModel target = MakeRig(Humanoid(3, kPi / 12));
  const Posed posed = Pose(source, RandomPoses(source.size(), 20, 5), RowMatrixXd::Zero(20, 3 * source.size()));
  const int arm = target.Find("upper_arm"), forearm = target.Find("forearm");
  for (const bool keep : {true, false}) {
    RetargetOptions options;
    if (keep) {
      options.posture_bones.push_back(arm);
      options.posture_bones.push_back(forearm);
    }
    RowMatrixXd rotations;
    const std::vector<int> kept = KeptPosture(source, target, posed, options, &rotations);
    EXPECT_EQ(kept, keep ? std::vector<int>({arm, forearm}) : std::vector<int>{});
    const Posed result = Pose(target, rotations, RowMatrixXd::Zero(20, 3 * target.size()));
    for (int f = 0; f < 20; ++f) {
      for (const int b : {arm, forearm}) {
        const int a = source.Find(target.name(b));
        const double angle = AngleDeg(Direction(result.rotations, f, b), Direction(posed.rotations, f, a));
        EXPECT_NEAR(angle, keep ? 15.0 : 0.0, 1e-9) << target.name(b) << " frame " << f;
        if (!keep) continue;
        const Eigen::Quaterniond turned = QuatAt(result.rotations, f, b) * target.rest(b).conjugate();
        const Eigen::Quaterniond wanted = QuatAt(posed.rotations, f, a) * source.rest(a).conjugate();
        EXPECT_LT(turned.angularDistance(wanted), 1e-9) << target.name(b) << " frame " << f;
      }
    }
  }
}

// A posture bone its parents carry 60 degrees across the source's stands in another pose: turned onto the
// source's direction, and left out of kept_posture; in posture_always (the user's choice) it is kept.
TEST(Retarget, APostureBone60DegreesAcrossIsTurnedUnlessAlwaysKept) {
  const RigModel source = MakeRig(Humanoid(3, 0.0));
  const RigModel target = MakeRig(Humanoid(3, kPi / 3));
  const Posed posed = Pose(source, RandomPoses(source.size(), 5, 6), RowMatrixXd::Zero(5, 3 * source.size()));
  const int arm = target.Find("upper_arm"), a = source.Find("upper_arm");
  for (const bool always : {false, true}) {
    RetargetOptions options;
    (always ? options.posture_always : options.posture_bones).push_back(arm);
    RowMatrixXd rotations;
    const std::vector<int> kept = KeptPosture(source, target, posed, options, &rotations);
    EXPECT_EQ(kept, always ? std::vector<int>{arm} : std::vector<int>{});
    const Posed result = Pose(target, rotations, RowMatrixXd::Zero(5, 3 * target.size()));
    for (int f = 0; f < 5; ++f) {
      EXPECT_NEAR(AngleDeg(Direction(result.rotations, f, arm), Direction(posed.rotations, f, a)),
                  always ? 60.0 : 0.0, 1e-9) << "frame " << f;
    }
  }
  RetargetOptions bad;
  bad.posture_always.push_back(target.size());
  RowMatrixXd rotations;
  EXPECT_THROW(KeptPosture(source, target, posed, bad, &rotations), Error);
}

// A one-bone neck onto a two-bone neck: the target's second neck bone, left out of the map between the
// neck and the head, lies within the source neck's reach and shares its turn, so both point as it does.
// A pelvis both legs hang from, left out of the map, follows neither leg: the hips carry it.
TEST(Retarget, ASecondNeckBoneSharesTheNecksTurnAndAPelvisIsCarried) {
  const std::vector<BoneSpec> one{{"hips", -1, {0, 0, 1.0}, {0, 0, 1.1}, 0.0},
                                  {"thigh.L", 0, {0.1, 0, 1.0}, {0.1, 0, 0.55}, 0.0},
                                  {"thigh.R", 0, {-0.1, 0, 1.0}, {-0.1, 0, 0.55}, 0.0},
                                  {"chest", 0, {0, 0, 1.1}, {0, 0, 1.5}, 0.0},
                                  {"neck", 3, {0, 0, 1.5}, {0, 0.02, 1.62}, 0.0},
                                  {"head", 4, {0, 0.02, 1.62}, {0, 0.02, 1.8}, 0.0}};
  const std::vector<BoneSpec> two{{"hips", -1, {0, 0, 1.0}, {0, 0, 1.1}, 0.0},
                                  {"pelvis", 0, {0, 0, 1.0}, {0, 0, 0.95}, 0.0},
                                  {"thigh.L", 1, {0.1, 0, 1.0}, {0.1, 0, 0.55}, 0.0},
                                  {"thigh.R", 1, {-0.1, 0, 1.0}, {-0.1, 0, 0.55}, 0.0},
                                  {"chest", 0, {0, 0, 1.1}, {0, 0, 1.5}, 0.0},
                                  {"neck", 4, {0, 0, 1.5}, {0, 0.01, 1.56}, 0.0},
                                  {"neck.001", 5, {0, 0.01, 1.56}, {0, 0.02, 1.62}, 0.0},
                                  {"head", 6, {0, 0.02, 1.62}, {0, 0.02, 1.8}, 0.0}};
  const RigModel source = MakeRig(one), target = MakeRig(two);
  const Posed posed = Pose(source, RandomPoses(source.size(), 10, 8), RowMatrixXd::Zero(10, 3 * source.size()));
  RowMatrixXd rotations;
  KeptPosture(source, target, posed, {}, &rotations);
  const Posed result = Pose(target, rotations, RowMatrixXd::Zero(10, 3 * target.size()));
  const int pelvis = target.Find("pelvis");
  for (int f = 0; f < 10; ++f) {
    for (const char* name : {"neck", "neck.001"}) {
      EXPECT_LT(AngleDeg(Direction(result.rotations, f, target.Find(name)), Direction(posed.rotations, f, 4)), 1e-9)
          << name << " frame " << f;
    }
    const Eigen::Quaterniond carried = QuatAt(result.rotations, f, 0) * target.relative(pelvis);
    EXPECT_LT(QuatAt(result.rotations, f, pelvis).angularDistance(carried), 1e-9) << "pelvis, frame " << f;
  }
}

// A trunk kept in the target's posture (posture_bones) with an unmapped helper joint (helper_bones) between
// the neck and the head, standing off the line, where the neck's axis points nowhere near the head (as a
// bone whose only child starts at its own head): each mapped bone turns as its source bone from its own rest
// and the helper stays as its neck carries it, as Mixamo's retargets leave their `*_split` joints.
TEST(Retarget, InAKeptChainAHelperBetweenMappedBonesIsCarried) {
  const std::vector<BoneSpec> one{{"hips", -1, {0, 0, 1.0}, {0, 0, 1.1}, 0.0},
                                  {"chest", 0, {0, 0, 1.1}, {0, 0, 1.5}, 0.0},
                                  {"neck", 1, {0, 0, 1.5}, {0, 0.02, 1.62}, 0.0},
                                  {"head", 2, {0, 0.02, 1.62}, {0, 0.02, 1.8}, 0.0}};
  const std::vector<BoneSpec> two{{"hips", -1, {0, 0, 1.0}, {0, 0, 1.1}, 0.0},
                                  {"chest", 0, {0, 0, 1.1}, {0, 0.03, 1.5}, 0.0},
                                  {"neck", 1, {0, 0.03, 1.5}, {0, 0.05, 1.56}, 0.0},
                                  {"neck.001", 2, {0, 0.05, 1.56}, {0, 0.02, 1.62}, 0.0},
                                  {"head", 3, {0, 0.02, 1.62}, {0, 0.02, 1.8}, 0.0}};
  const RigModel source = MakeRig(one), target = MakeRig(two);
  const Posed posed = Pose(source, RandomPoses(source.size(), 10, 9), RowMatrixXd::Zero(10, 3 * source.size()));
  RetargetOptions options;
  for (int b = 0; b < target.size(); ++b) options.posture_bones.push_back(b);
  options.helper_bones.push_back(target.Find("neck.001"));
  RowMatrixXd rotations;
  const std::vector<int> kept = KeptPosture(source, target, posed, options, &rotations);
  EXPECT_EQ(kept.size(), static_cast<std::size_t>(target.size()));
  const Posed result = Pose(target, rotations, RowMatrixXd::Zero(10, 3 * target.size()));
  const int neck = target.Find("neck"), between = target.Find("neck.001");
  for (int f = 0; f < 10; ++f) {
    for (const char* name : {"hips", "chest", "neck", "head"}) {
      const int b = target.Find(name), a = source.Find(name);
      const Eigen::Quaterniond ours = QuatAt(result.rotations, f, b) * target.rest(b).conjugate();
      const Eigen::Quaterniond theirs = QuatAt(posed.rotations, f, a) * source.rest(a).conjugate();
      EXPECT_LT(ours.angularDistance(theirs), 1e-9) << name << " frame " << f;
    }
    const Eigen::Quaterniond carried = QuatAt(result.rotations, f, neck) * target.relative(between);
    EXPECT_LT(QuatAt(result.rotations, f, between).angularDistance(carried), 1e-9) << "frame " << f;
  }
}

// Mixamo's `*_split` joints: the target's clavicle runs to a helper joint 63 degrees up before its arm, the
// source's straight to its arm. Aimed past the helper at the arm (target_aims) with the helper among
// helper_bones, the clavicle turns as the source's and the helper is carried; without helper_bones the
// helper is turned along the chain as a segment would be.
TEST(Retarget, AHelperJointTheMappedBoneAimsPastIsCarried) {
  const std::vector<BoneSpec> plain{{"hips", -1, {0, 0, 1.0}, {0, 0, 1.1}, 0.0},
                                    {"chest", 0, {0, 0, 1.1}, {0, 0, 1.4}, 0.0},
                                    {"clavicle", 1, {0.02, 0, 1.45}, {0.15, 0, 1.45}, 0.0},
                                    {"arm", 2, {0.15, 0, 1.45}, {0.4, 0, 1.45}, 0.0}};
  const std::vector<BoneSpec> split{{"hips", -1, {0, 0, 1.0}, {0, 0, 1.1}, 0.0},
                                    {"chest", 0, {0, 0, 1.1}, {0, 0, 1.4}, 0.0},
                                    {"clavicle", 1, {0.02, 0, 1.45}, {0.04, 0, 1.49}, 0.0},
                                    {"clavicle_split", 2, {0.04, 0, 1.49}, {0.15, 0, 1.45}, 0.0},
                                    {"arm", 3, {0.15, 0, 1.45}, {0.4, 0, 1.45}, 0.0}};
  const RigModel source = MakeRig(plain), target = MakeRig(split);
  const int frames = 8;
  const Posed posed = Pose(source, RandomPoses(source.size(), frames, 5), RowMatrixXd::Zero(frames, 3 * source.size()));
  RowMatrixXd aims(target.size(), 3);
  for (int b = 0; b < target.size(); ++b) aims.row(b) = Eigen::Vector3d::UnitY().transpose();
  const int clavicle = target.Find("clavicle"), helper = target.Find("clavicle_split");
  aims.row(clavicle) =
      (target.rest(clavicle).conjugate() * (target.head(target.Find("arm")) - target.head(clavicle)).normalized())
          .transpose();
  auto run = [&](std::vector<int> helpers) {
    RetargetOptions options;
    options.helper_bones = std::move(helpers);
    const Retargeted out = Retarget(source, target, posed, options, {}, aims);
    return Pose(target, out.rotations, RowMatrixXd::Zero(frames, 3 * target.size()));
  };
  const Posed carried = run({helper}), chained = run({});
  double turned = 0.0;
  for (int f = 0; f < frames; ++f) {
    // The clavicle's world turn from its rest is the source's (rounding of a few products: 1e-9).
    const Eigen::Quaterniond ours = QuatAt(carried.rotations, f, clavicle) * target.rest(clavicle).conjugate();
    const Eigen::Quaterniond theirs = QuatAt(posed.rotations, f, 2) * source.rest(2).conjugate();
    EXPECT_LT(ours.angularDistance(theirs), 1e-9) << "frame " << f;
    const Eigen::Quaterniond held = QuatAt(carried.rotations, f, clavicle) * target.relative(helper);
    EXPECT_LT(QuatAt(carried.rotations, f, helper).angularDistance(held), 1e-9) << "helper, frame " << f;
    turned = std::max(turned, QuatAt(chained.rotations, f, helper).angularDistance(
                                  QuatAt(chained.rotations, f, clavicle) * target.relative(helper)));
  }
  EXPECT_GT(turned, 0.1);  // radians: as a segment the helper turns along the chain
}

TEST(Retarget, RootMotionScalesAndGroundsAsAsked) {
  const RigModel source = MakeRig(Humanoid(3, 0.0));
  const RigModel target = MakeRig(Humanoid(3, 0.0, 0.0, 0.5));  // half the size
  const int frames = 5;
  const RowMatrixXd basis = RandomPoses(source.size(), frames, 9, 0.0);  // rest every frame
  RowMatrixXd locations = RowMatrixXd::Zero(frames, 3 * source.size());
  for (int f = 0; f < frames; ++f) locations.row(f).head<3>() << 0.2 * f, 0.1 * f, 0.04 * f;
  const Posed posed = Pose(source, basis, locations);
  // The target root's head moved from rest, in armature space. Both rigs stand
  // on Z = 0, so scaled heights are scaled moves.
  const auto root_at = [&](RetargetOptions o, int f) {
    const Retargeted run = Retarget(source, target, posed, o);
    RowMatrixXd target_locations = RowMatrixXd::Zero(frames, 3 * target.size());
    target_locations.leftCols(3) = run.roots;
    const Posed result = Pose(target, run.rotations, target_locations);
    return Eigen::Vector3d(result.heads.row(f).head<3>().transpose() - target.head(0));
  };
  const Eigen::Vector3d moved = posed.heads.row(4).head<3>().transpose() - source.head(0);
  ASSERT_GT(std::abs(moved.x()) * std::abs(moved.y()) * std::abs(moved.z()), 1e-4);
  RetargetOptions o;
  o.scale = 0.5;
  EXPECT_NEAR((root_at(o, 4) - 0.5 * moved).norm(), 0, 1e-12);
  // The stride scaled on its own: across the floor 1.3 times more, the height as before.
  o.scale_horizontal = 1.3;
  EXPECT_NEAR((root_at(o, 4) - Eigen::Vector3d(0.65 * moved.x(), 0.65 * moved.y(), 0.5 * moved.z())).norm(), 0,
              1e-12);
  o.root_motion = RootMotion::kInPlace;
  EXPECT_NEAR((root_at(o, 4) - Eigen::Vector3d(0, 0, 0.5 * moved.z())).norm(), 0, 1e-12);
  o.scale_horizontal = 1.0;
  // Unscaled height (in twice the units) plus the offset that makes standing heights agree.
  o.root_motion = RootMotion::kOffset;
  o.unit_scale = 2.0;
  o.vertical_offset = target.head(0).z() - 2.0 * source.head(0).z();
  EXPECT_NEAR((root_at(o, 4) - Eigen::Vector3d(0.5 * moved.x(), 0.5 * moved.y(), 2.0 * moved.z())).norm(), 0,
              1e-12);
  o.root_motion = RootMotion::kNone;
  EXPECT_NEAR(root_at(o, 4).norm(), 0, 1e-12);
}

// Frames are posed in blocks on threads: every frame is computed as on one thread, so any number of threads
// gives the same bits, over more frames than a block holds.
TEST(Retarget, ThreadsChangeNothing) {
  const RigModel source = MakeRig(Humanoid(3, 0.0));
  const RigModel target = MakeRig(Humanoid(4, 0.6, 0.37, 1.2));
  const int frames = static_cast<int>(2 * ArmaturePoseJob::kFramesPerBlock + 37);
  const RowMatrixXd basis = RandomPoses(source.size(), frames, 11);
  RowMatrixXd locations = RowMatrixXd::Zero(frames, 3 * source.size());
  for (int f = 0; f < frames; ++f) locations.row(f).head<3>() << 0.001 * f, 0.02 * std::sin(0.1 * f), 0.0;
  std::vector<Posed> poses;
  std::vector<Retargeted> runs;
  std::vector<int> map;
  for (int b = 0; b < target.size(); ++b) map.push_back(source.Find(target.name(b)));
  for (const int threads : {1, 2, 5}) {
    Posed p{RowMatrixXd(frames, 4 * source.size()), RowMatrixXd(frames, 3 * source.size())};
    ArmaturePoseJob job(source, basis, locations, p.rotations, p.heads);
    job.threads = threads;
    job.Run();
    poses.push_back(p);
    RetargetOptions o;
    o.threads = threads;
    runs.push_back(Retarget(source, target, p, o, map));
  }
  for (std::size_t k = 1; k < runs.size(); ++k) {
    EXPECT_EQ(poses[k].rotations, poses[0].rotations);
    EXPECT_EQ(poses[k].heads, poses[0].heads);
    EXPECT_EQ(runs[k].rotations, runs[0].rotations);
    EXPECT_EQ(runs[k].roots, runs[0].roots);
  }
  RetargetOptions bad;
  bad.threads = -1;
  EXPECT_THROW(Retarget(source, target, poses[0], bad, map), Error);
}

TEST(Retarget, BadMapsAreRefusedWithTheirBones) {
  const RigModel rig = MakeRig(Humanoid(3, 0.0));
  const Posed posed = Pose(rig, RandomPoses(rig.size(), 2, 1), RowMatrixXd::Zero(2, 3 * rig.size()));
  std::vector<int> none(static_cast<std::size_t>(rig.size()), -1);
  EXPECT_THROW(
      {
        try {
          Retarget(rig, rig, posed, {}, none);
        } catch (const Error& e) {
          EXPECT_NE(std::string(e.what()).find("no common bones"), std::string::npos);
          throw;
        }
      },
      Error);
  // Swap the upper arm and forearm: target upper_arm (above) gets the source forearm (below).
  std::vector<int> crossed;
  for (int b = 0; b < rig.size(); ++b) crossed.push_back(b);
  std::swap(crossed[static_cast<std::size_t>(rig.Find("upper_arm"))],
            crossed[static_cast<std::size_t>(rig.Find("forearm"))]);
  try {
    Retarget(rig, rig, posed, {}, crossed);
    FAIL() << "a crossing map was accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("cycle"), std::string::npos) << m;
    EXPECT_NE(m.find("'upper_arm'"), std::string::npos) << m;
  }
  Posed broken = posed;
  broken.rotations(1, 4 * 2 + 1) = std::nan("");
  try {
    Retarget(rig, rig, broken);
    FAIL() << "a NaN rotation was accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("'spine1'"), std::string::npos) << m;
    EXPECT_NE(m.find("frame index 1"), std::string::npos) << m;
  }
}

TEST(Rig, RefusesChildrenBeforeParents) {
  std::vector<BoneSpec> bones = {{"a", 1, {0, 0, 0}, {0, 1, 0}, 0}, {"b", -1, {0, 1, 0}, {0, 2, 0}, 0}};
  EXPECT_THROW(MakeRig(bones), Error);
}

}  // namespace
}  // namespace motionkit

namespace motionkit {
namespace {

TEST(Rig, TakesBlendersFloat32RestRotationsAndRefusesGarbage) {
  RowMatrixXd rest(1, 4), heads = RowMatrixXd::Zero(1, 3);
  Eigen::VectorXd lengths = Eigen::VectorXd::Ones(1);
  rest << 1.0 + 5e-6, 0, 0, 0;  // a float32 matrix's quaternion
  const RigModel rig({"a"}, {-1}, rest, heads, lengths);
  EXPECT_NEAR(rig.rest(0).norm(), 1.0, 1e-15);
  rest << 0.5, 0, 0, 0;
  EXPECT_THROW(RigModel({"a"}, {-1}, rest, heads, lengths), Error);
}

}  // namespace
}  // namespace motionkit
