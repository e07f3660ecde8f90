#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "motionkit/ik.hpp"
#include "motionkit/rig.hpp"

namespace motionkit {
namespace {

constexpr double kPi = 3.14159265358979323846;
using Vec3 = Eigen::Vector3d;
using Quat = Eigen::Quaterniond;

struct BoneSpec {
  std::string name;
  int parent;
  Vec3 head, tail;
  double roll;
};

// Rest orientation as Blender makes it from head, tail and roll.
Quat RestOf(const BoneSpec& b) {
  const Vec3 d = (b.tail - b.head).normalized();
  return (Eigen::AngleAxisd(b.roll, d) * Quat::FromTwoVectors(Vec3::UnitY(), d)).normalized();
}

RigModel MakeRig(const std::vector<BoneSpec>& bones) {
  std::vector<std::string> names;
  std::vector<int> parents;
  const auto n = static_cast<Eigen::Index>(bones.size());
  RowMatrixXd rest(n, 4), heads(n, 3);
  Eigen::VectorXd lengths(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const BoneSpec& b = bones[static_cast<std::size_t>(i)];
    names.push_back(b.name);
    parents.push_back(b.parent);
    const Quat q = RestOf(b);
    rest.row(i) << q.w(), q.x(), q.y(), q.z();
    heads.row(i) = b.head.transpose();
    lengths[i] = (b.tail - b.head).norm();
  }
  return RigModel(names, parents, rest, heads, lengths);
}

// A straight chain of `n` bones along `direction` from the origin.
std::vector<BoneSpec> Chain(const std::vector<double>& lengths, const Vec3& direction, double roll = 0.0) {
  std::vector<BoneSpec> b;
  Vec3 at = Vec3::Zero();
  for (std::size_t i = 0; i < lengths.size(); ++i) {
    const Vec3 next = at + lengths[i] * direction.normalized();
    b.push_back({"b" + std::to_string(i), static_cast<int>(i) - 1, at, next, roll * static_cast<double>(i)});
    at = next;
  }
  return b;
}

// A humanoid of 20 bones: hips, two spine bones, head, and per side a
// clavicle, upper arm, forearm, hand, thigh, shin, foot and toe. `rng` jitters
// proportions, arm angle and rolls; none: a plain T-pose.
std::vector<BoneSpec> Humanoid(std::mt19937* rng = nullptr) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto jitter = [&](double x) { return rng ? x * (0.8 + 0.4 * u(*rng)) : x; };
  const auto roll = [&]() { return rng ? (2 * u(*rng) - 1) * kPi : 0.0; };
  const double arm_down = rng ? u(*rng) * kPi / 3 : 0.0;
  std::vector<BoneSpec> b;
  const double hip = jitter(1.0);
  b.push_back({"hips", -1, {0, 0, hip}, {0, 0, hip + jitter(0.1)}, roll()});
  Vec3 at = b[0].tail;
  int parent = 0;
  for (int i = 0; i < 2; ++i) {
    const Vec3 next = at + Vec3(0, 0, jitter(0.2));
    b.push_back({"spine" + std::to_string(i), parent, at, next, roll()});
    parent = static_cast<int>(b.size()) - 1;
    at = next;
  }
  const int chest = parent;
  const Vec3 neck = at;
  b.push_back({"head", chest, neck, neck + Vec3(0, 0, jitter(0.25)), roll()});
  for (const double side : {1.0, -1.0}) {
    const std::string s = side > 0 ? "_l" : "_r";
    const Vec3 shoulder = neck + Vec3(side * jitter(0.18), 0, -jitter(0.05));
    b.push_back({"clavicle" + s, chest, neck + Vec3(side * 0.02, 0, -0.05), shoulder, roll()});
    const Vec3 dir(side * std::cos(arm_down), 0, -std::sin(arm_down));
    const Vec3 elbow = shoulder + jitter(0.3) * dir, wrist = elbow + jitter(0.26) * dir;
    b.push_back({"upper_arm" + s, static_cast<int>(b.size()) - 1, shoulder, elbow, roll()});
    b.push_back({"forearm" + s, static_cast<int>(b.size()) - 1, elbow, wrist, roll()});
    b.push_back({"hand" + s, static_cast<int>(b.size()) - 1, wrist, wrist + jitter(0.08) * dir, roll()});
  }
  for (const double side : {1.0, -1.0}) {
    const std::string s = side > 0 ? "_l" : "_r";
    const Vec3 hip_joint(side * jitter(0.1), 0, hip);
    const Vec3 knee(hip_joint.x(), -0.01, hip * jitter(0.52)), ankle(hip_joint.x(), 0, hip * jitter(0.1));
    const Vec3 ball(hip_joint.x(), -jitter(0.12), 0.03);
    b.push_back({"thigh" + s, 0, hip_joint, knee, roll()});
    b.push_back({"shin" + s, static_cast<int>(b.size()) - 1, knee, ankle, roll()});
    b.push_back({"foot" + s, static_cast<int>(b.size()) - 1, ankle, ball, roll()});
    b.push_back({"toe" + s, static_cast<int>(b.size()) - 1, ball, ball + Vec3(0, -jitter(0.06), 0), roll()});
  }
  return b;
}

// Test-side forward kinematics (independent of the solver's): armature-space
// orientations, heads and tails, with the stretch model of ik.hpp.
struct Posed {
  std::vector<Quat> global;
  std::vector<Vec3> head, tail;
};

Posed Fk(const RigModel& rig, const RowMatrixXd& rotations, Eigen::Index row, const Vec3& root_location,
         const RowMatrixXd* scales = nullptr) {
  Posed p;
  for (int b = 0; b < rig.size(); ++b) {
    const Quat basis = QuatAt(rotations, row, b).normalized();
    const int parent = rig.parent(b);
    const double s = scales ? (*scales)(row, b) : 1.0;
    if (parent < 0) {
      p.global.push_back(rig.relative(b) * basis);
      p.head.push_back(rig.offset(b) + (b == 0 ? Vec3(rig.relative(b) * root_location) : Vec3::Zero()));
    } else {
      const auto pi = static_cast<std::size_t>(parent);
      Vec3 offset = rig.offset(b);
      offset.y() *= scales ? (*scales)(row, parent) : 1.0;
      p.global.push_back(p.global[pi] * rig.relative(b) * basis);
      p.head.push_back(p.head[pi] + p.global[pi] * offset);
    }
    p.tail.push_back(p.head.back() + p.global.back() * Vec3(0, s * rig.length(b), 0));
  }
  return p;
}

RowMatrixXd Identity(int bones, Eigen::Index frames = 1) {
  RowMatrixXd q = RowMatrixXd::Zero(frames, 4 * bones);
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (int b = 0; b < bones; ++b) q(f, 4 * b) = 1.0;
  }
  return q;
}

Quat RandomRotation(std::mt19937& rng, double spread) {
  std::normal_distribution<double> n(0.0, spread);
  const Vec3 v(n(rng), n(rng), n(rng));
  const double a = v.norm();
  return a < 1e-300 ? Quat::Identity() : Quat(Eigen::AngleAxisd(a, v / a));
}

void SetQuat(RowMatrixXd& m, Eigen::Index row, int bone, const Quat& q) {
  m.row(row).segment<4>(4 * bone) << q.w(), q.x(), q.y(), q.z();
}

// A job with its inputs and outputs, for a given number of frames.
struct Problem {
  const RigModel* rig = nullptr;
  std::vector<IkEffector> effectors;
  std::vector<IkJoint> joints;
  IkOptions options;
  RowMatrixXd input_rotations, input_locations, target_positions, target_orientations;
  RowMatrixXd rotations, root_locations, scales, errors;
  Eigen::VectorXi iterations;

  Problem(const RigModel& r, Eigen::Index frames, std::vector<IkEffector> e) : rig(&r), effectors(std::move(e)) {
    const auto count = static_cast<Eigen::Index>(effectors.size());
    input_rotations = Identity(r.size());
    input_locations = RowMatrixXd::Zero(1, 3);
    target_positions = RowMatrixXd::Zero(frames, 3 * count);
    target_orientations = RowMatrixXd::Zero(frames, 0);
  }
  IkClipJob Job() {
    const Eigen::Index frames = target_positions.rows();
    rotations.setConstant(frames, 4 * rig->size(), -7.0);
    root_locations.setConstant(frames, 3, -7.0);
    scales.setConstant(frames, rig->size(), -7.0);
    errors.setConstant(frames, static_cast<Eigen::Index>(effectors.size()), -7.0);
    iterations.setConstant(frames, -7);
    IkClipJob job(*rig, input_rotations, input_locations, target_positions, target_orientations, rotations,
                  root_locations, scales, errors, iterations);
    job.effectors = effectors;
    job.joints = joints;
    job.options = options;
    return job;
  }
  void Run() { Job().Run(); }
  Posed Output(Eigen::Index f) const {
    return Fk(*rig, rotations, f, root_locations.row(f).transpose(), &scales);
  }
  Posed Input(Eigen::Index f) const {
    const Eigen::Index lr = input_locations.rows() == 1 ? 0 : f;
    return Fk(*rig, input_rotations, input_rotations.rows() == 1 ? 0 : f, input_locations.row(lr).transpose());
  }
  Vec3 Tip(Eigen::Index f, int effector) const {
    return Output(f).tail[static_cast<std::size_t>(effectors[static_cast<std::size_t>(effector)].bone)];
  }
  void SetTarget(Eigen::Index f, int effector, const Vec3& t) { target_positions.row(f).segment<3>(3 * effector) = t; }
};

IkEffector Effector(const std::string& name, int bone, bool pin = false) {
  IkEffector e;
  e.name = name;
  e.bone = bone;
  e.pin = pin;
  return e;
}

const IkMethod kMethods[] = {IkMethod::kCcd, IkMethod::kTranspose, IkMethod::kPseudoInverse, IkMethod::kDls};
const char* MethodName(IkMethod m) {
  switch (m) {
    case IkMethod::kCcd:
      return "ccd";
    case IkMethod::kTranspose:
      return "transpose";
    case IkMethod::kPseudoInverse:
      return "pinv";
    case IkMethod::kDls:
      return "dls";
  }
  return "?";
}

Vec3 Log(const Quat& q) {
  const Eigen::AngleAxisd aa(q.w() < 0 ? Quat(-q.coeffs()) : q);
  return aa.angle() * aa.axis();
}

double AngleBetween(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

TEST(IkSwingTwist, SplitsAndJoinsBack) {
  std::mt19937 rng(3);
  for (int i = 0; i < 1000; ++i) {
    const Quat q = RandomRotation(rng, 1.0);
    const Vec3 a = IkSwingTwist(q);
    EXPECT_LE(std::abs(a.y()), kPi + 1e-12);
    EXPECT_LT(IkFromSwingTwist(a).angularDistance(q), 1e-12);
    // The twist is about Y; the swing's axis lies in the X-Z plane.
    const Quat twist(Eigen::AngleAxisd(a.y(), Vec3::UnitY()));
    const Quat swing = q * twist.conjugate();
    EXPECT_NEAR(swing.y(), 0.0, 1e-12);
  }
  EXPECT_EQ(ParseIkMethod("dls"), IkMethod::kDls);
  EXPECT_EQ(ParseIkMethod("pinv"), IkMethod::kPseudoInverse);
  EXPECT_FALSE(ParseIkMethod("fabrik").has_value());
}

// A planar two-bone arm along +X with hinges about Z: every method finds the
// law of cosines' angles (elbow on the side it starts bent to).
TEST(IkArm, TwoBonePlanarMatchesLawOfCosines) {
  const double l1 = 1.0, l2 = 0.7;
  const RigModel rig = MakeRig(Chain({l1, l2}, Vec3::UnitX()));
  // The rest frames' Z is world Z (a bone along X, no roll).
  ASSERT_LT((rig.rest(0) * Vec3::UnitZ() - Vec3::UnitZ()).norm(), 1e-12);
  const Vec3 target(0.9, 0.8, 0.0);
  const double d = target.norm();
  const double elbow = std::acos((d * d - l1 * l1 - l2 * l2) / (2 * l1 * l2));
  const double shoulder = std::atan2(target.y(), target.x()) - std::atan2(l2 * std::sin(elbow), l1 + l2 * std::cos(elbow));
  for (IkMethod method : kMethods) {
    Problem p(rig, 1, {Effector("hand", 1)});
    p.joints.resize(2);
    for (IkJoint& j : p.joints) j.locked = {{true, true, false}};
    SetQuat(p.input_rotations, 0, 1, Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ())));
    p.options.method = method;
    p.options.root_rotation = true;
    p.options.tolerance = 1e-10;
    p.options.max_iterations = 500;
    p.SetTarget(0, 0, target);
    p.Run();
    const Vec3 a0 = IkSwingTwist(QuatAt(p.rotations, 0, 0)), a1 = IkSwingTwist(QuatAt(p.rotations, 0, 1));
    EXPECT_NEAR(a0.z(), shoulder, 1e-8) << MethodName(method);
    EXPECT_NEAR(a1.z(), elbow, 1e-8) << MethodName(method);
    EXPECT_NEAR(a0.x(), 0.0, 1e-12);
    EXPECT_NEAR(a1.y(), 0.0, 1e-12);
    EXPECT_LT(p.errors(0, 0), 1e-9) << MethodName(method);
    EXPECT_LT((p.Tip(0, 0) - target).norm(), 1e-9) << MethodName(method);
  }
}

// The solver's Jacobian against central differences of an independent FK.
TEST(IkJacobian, ColumnsMatchFiniteDifferencesOfFk) {
  std::mt19937 rng(11);
  const RigModel rig = MakeRig(Humanoid(&rng));
  const int hand = rig.Find("hand_l"), foot = rig.Find("toe_r"), chest = rig.Find("spine1");
  Problem p(rig, 1, {Effector("hand", hand), Effector("foot", foot), Effector("chest", chest)});
  p.effectors[0].orientation = true;
  p.effectors[0].weight = 2.0;
  p.effectors[2].orientation = true;
  p.effectors[2].position = false;
  p.target_orientations = Identity(3);
  p.joints.resize(static_cast<std::size_t>(rig.size()));
  p.joints[static_cast<std::size_t>(rig.Find("forearm_l"))].locked = {{true, false, true}};
  p.joints[static_cast<std::size_t>(rig.Find("upper_arm_l"))].stiffness = Vec3(0.5, 0.0, 0.25);
  p.joints[static_cast<std::size_t>(rig.Find("spine0"))].excluded = true;
  for (int b = 0; b < rig.size(); ++b) SetQuat(p.input_rotations, 0, b, RandomRotation(rng, 0.5));
  // Within its limits (a hinge about Y), or the solver would start elsewhere.
  SetQuat(p.input_rotations, 0, rig.Find("forearm_l"), Quat(Eigen::AngleAxisd(0.4, Vec3::UnitY())));
  p.input_locations << 0.1, -0.2, 0.3;
  p.options.root_translation = true;
  p.options.root_rotation = true;
  p.options.orientation_scale = 0.4;
  const RowMatrixXd j = p.Job().Jacobian(0);
  // Columns: translation, then per solved bone in order its free axes.
  struct Col {
    int bone;  // -1: translation
    int axis;
    double scale;
  };
  std::vector<Col> cols;
  for (int k = 0; k < 3; ++k) cols.push_back({-1, k, 1.0});
  for (int b = 0; b < rig.size(); ++b) {
    if (!(rig.IsAncestor(b, hand) || rig.IsAncestor(b, foot) || rig.IsAncestor(b, chest))) continue;
    const IkJoint& joint = p.joints[static_cast<std::size_t>(b)];
    if (joint.excluded) continue;
    for (int k = 0; k < 3; ++k) {
      if (!joint.locked[static_cast<std::size_t>(k)]) cols.push_back({b, k, 1.0 - joint.stiffness[k]});
    }
  }
  ASSERT_EQ(j.rows(), 6 + 3 + 3);
  ASSERT_EQ(j.cols(), static_cast<Eigen::Index>(cols.size()));
  const double ls = 0.4, h = 1e-6;
  for (std::size_t c = 0; c < cols.size(); ++c) {
    // Move the input by +-h along the column and compare effector motion.
    const auto moved = [&](double step) {
      RowMatrixXd rot = p.input_rotations;
      Vec3 loc = p.input_locations.row(0).transpose();
      if (cols[c].bone < 0) {
        loc += rig.relative(0).conjugate() * (ls * step * Vec3::Unit(cols[c].axis));
      } else {
        const Quat q = QuatAt(rot, 0, cols[c].bone);
        SetQuat(rot, 0, cols[c].bone,
                Quat(Eigen::AngleAxisd(cols[c].scale * step, Vec3::Unit(cols[c].axis))) * q);
      }
      return Fk(rig, rot, 0, loc);
    };
    const Posed plus = moved(h), minus = moved(-h);
    const auto b = [](int bone) { return static_cast<std::size_t>(bone); };
    const Vec3 hand_velocity = (plus.tail[b(hand)] - minus.tail[b(hand)]) / (2 * h);
    const Vec3 hand_spin = Log(plus.global[b(hand)] * minus.global[b(hand)].conjugate()) / (2 * h);
    const Vec3 foot_velocity = (plus.tail[b(foot)] - minus.tail[b(foot)]) / (2 * h);
    const Vec3 chest_spin = Log(plus.global[b(chest)] * minus.global[b(chest)].conjugate()) / (2 * h);
    const auto col = static_cast<Eigen::Index>(c);
    const double sw = std::sqrt(2.0);
    EXPECT_LT((j.col(col).segment<3>(0) - sw * hand_velocity).norm(), 1e-7) << "column " << c;
    EXPECT_LT((j.col(col).segment<3>(3) - sw * ls * hand_spin).norm(), 1e-7) << "column " << c;
    EXPECT_LT((j.col(col).segment<3>(6) - foot_velocity).norm(), 1e-7) << "column " << c;
    EXPECT_LT((j.col(col).segment<3>(9) - ls * chest_spin).norm(), 1e-7) << "column " << c;
  }
}


// A random pose of every bone (and the root's location), `spread` radians.
void RandomPose(RowMatrixXd& rotations, Eigen::Index row, int bones, std::mt19937& rng, double spread) {
  for (int b = 0; b < bones; ++b) SetQuat(rotations, row, b, RandomRotation(rng, spread));
}

TEST(IkMethods, EachConvergesOnAReachableSingleTarget) {
  std::mt19937 rng(5);
  const RigModel rig = MakeRig(Chain({0.5, 0.4, 0.3, 0.2}, Vec3(0.2, 1, 0.1), 0.7));
  for (IkMethod method : kMethods) {
    const int cases = 20;
    int met = 0;
    for (int c = 0; c < cases; ++c) {
      Problem p(rig, 1, {Effector("tip", 3)});
      RowMatrixXd goal = Identity(rig.size());
      RandomPose(goal, 0, rig.size(), rng, 0.6);
      RandomPose(p.input_rotations, 0, rig.size(), rng, 0.3);
      p.SetTarget(0, 0, Fk(rig, goal, 0, Vec3::Zero()).tail[3]);
      p.options.method = method;
      p.options.root_rotation = true;
      // Gradient descent converges linearly, and slowly: a looser tolerance.
      const bool slow = method == IkMethod::kTranspose;
      p.options.tolerance = slow ? 1e-6 : 1e-8;
      p.options.max_iterations = method == IkMethod::kDls || method == IkMethod::kPseudoInverse ? 64 : 5000;
      p.Run();
      EXPECT_LT((p.Tip(0, 0) - p.target_positions.row(0).head<3>().transpose()).norm(), 1.01 * p.options.tolerance)
          << MethodName(method) << " case " << c << " after " << p.iterations[0] << " iterations";
      met += p.errors(0, 0) <= p.options.tolerance;
    }
    EXPECT_EQ(met, cases) << MethodName(method);
  }
}

// The 20-bone humanoid, its hands pulled, its feet pinned, hips free: a
// reachable pose (made from the input by re-posing spine and arms) is met and
// the feet do not move.
struct FullBody {
  RigModel rig;
  int hand_l, hand_r, toe_l, toe_r;
  explicit FullBody(std::mt19937* rng = nullptr)
      : rig(MakeRig(Humanoid(rng))),
        hand_l(rig.Find("hand_l")),
        hand_r(rig.Find("hand_r")),
        toe_l(rig.Find("toe_l")),
        toe_r(rig.Find("toe_r")) {}
  std::vector<IkEffector> Effectors() const {
    return {Effector("hand_l", hand_l), Effector("hand_r", hand_r), Effector("toe_l", toe_l, true),
            Effector("toe_r", toe_r, true)};
  }
  double Height() const { return rig.head(rig.Find("head")).z() + rig.length(rig.Find("head")); }
  bool UpperBody(int b) const {
    const std::string& n = rig.name(b);
    return n.rfind("spine", 0) == 0 || n.rfind("clavicle", 0) == 0 || n.rfind("upper_arm", 0) == 0 ||
           n.rfind("forearm", 0) == 0 || n.rfind("hand", 0) == 0;
  }
  // Input: a random pose, the root moved and turned a little. Targets: the
  // hands of the same pose with spine and arms posed anew.
  void Reachable(Problem& p, Eigen::Index f, std::mt19937& rng, double spread) const {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    if (p.input_rotations.rows() <= f) {
      p.input_rotations.conservativeResize(f + 1, Eigen::NoChange);
      p.input_locations.conservativeResize(f + 1, Eigen::NoChange);
    }
    RandomPose(p.input_rotations, f, rig.size(), rng, spread);
    SetQuat(p.input_rotations, f, 0, RandomRotation(rng, 0.2));
    p.input_locations.row(f) << 0.1 * u(rng), 0.1 * u(rng), 0.1 * u(rng);
    RowMatrixXd goal = p.input_rotations.row(f);
    for (int b = 0; b < rig.size(); ++b) {
      if (UpperBody(b)) SetQuat(goal, 0, b, RandomRotation(rng, spread));
    }
    const Posed posed = Fk(rig, goal, 0, p.input_locations.row(f).transpose());
    p.SetTarget(f, 0, posed.tail[static_cast<std::size_t>(hand_l)]);
    p.SetTarget(f, 1, posed.tail[static_cast<std::size_t>(hand_r)]);
  }
};

TEST(IkDls, FourEffectorsTwoPinsWithRootUnknowns) {
  std::mt19937 rng(17);
  const FullBody body(&rng);
  Problem p(body.rig, 1, body.Effectors());
  body.Reachable(p, 0, rng, 0.5);
  p.options.root_translation = true;
  p.options.root_rotation = true;
  p.options.tolerance = 1e-9;
  p.options.max_iterations = 200;
  p.Run();
  const Posed in = p.Input(0), out = p.Output(0);
  for (int e = 0; e < 4; ++e) EXPECT_LT(p.errors(0, e), 1e-9) << p.effectors[static_cast<std::size_t>(e)].name;
  for (int toe : {body.toe_l, body.toe_r}) {
    EXPECT_LT((out.tail[static_cast<std::size_t>(toe)] - in.tail[static_cast<std::size_t>(toe)]).norm(), 1e-6);
  }
  // The hips did move: the solution is not the input.
  EXPECT_GT((p.root_locations.row(0) - p.input_locations.row(0)).norm() +
                QuatAt(p.rotations, 0, 0).angularDistance(QuatAt(p.input_rotations, 0, 0)),
            1e-4);
}

// A target out of reach: the chain points straight at it, and more
// iterations change nothing (no jitter).
TEST(IkUnreachable, PointsStraightAtItWithoutJitter) {
  const RigModel rig = MakeRig(Chain({0.5, 0.4, 0.3}, Vec3::UnitY(), 0.4));
  const Vec3 target(1.5, 1.2, -0.6);  // 2.0 from the root; the chain reaches 1.2
  for (IkMethod method : kMethods) {
    std::vector<RowMatrixXd> results;
    const bool slow = method == IkMethod::kTranspose;  // gradient descent crawls near the straight line
    for (int iterations : {slow ? 2000 : 64, slow ? 10000 : 1000}) {
      Problem p(rig, 5, {Effector("tip", 2)});
      p.input_rotations = Identity(rig.size());
      SetQuat(p.input_rotations, 0, 1, Quat(Eigen::AngleAxisd(0.8, Vec3(1, 0, 1).normalized())));
      SetQuat(p.input_rotations, 0, 2, Quat(Eigen::AngleAxisd(-0.5, Vec3::UnitX())));
      for (int f = 0; f < 5; ++f) p.SetTarget(f, 0, target);
      p.options.method = method;
      p.options.root_rotation = true;
      p.options.max_iterations = iterations;
      p.Run();
      for (int f = 0; f < 5; ++f) {
        const Posed out = p.Output(f);
        for (int b = 0; b < 3; ++b) {
          const auto i = static_cast<std::size_t>(b);
          EXPECT_LT(AngleBetween(out.tail[i] - out.head[i], target), method == IkMethod::kDls ? 1e-3 : 1e-5)
              << MethodName(method) << " bone " << b << " frame " << f;
        }
        EXPECT_NEAR(p.errors(f, 0), target.norm() - 1.2, 1e-6) << MethodName(method);
      }
      results.push_back(p.rotations);
    }
    EXPECT_LT((results[0] - results[1]).cwiseAbs().maxCoeff(), 1e-9) << MethodName(method);
    // Warm-started frames on a still target do not move.
    EXPECT_LT((results[1].row(4) - results[1].row(1)).cwiseAbs().maxCoeff(), 1e-6) << MethodName(method);
  }
}

// A straight chain asked to fold (the target on its own line, nearer than
// its reach): the Jacobian has no column along the line; the solver still
// gets there, deterministically.
TEST(IkSingular, StraightChainFolds) {
  const RigModel rig = MakeRig(Chain({0.5, 0.5, 0.5}, Vec3::UnitY()));
  for (IkMethod method : kMethods) {
    for (const double reach : {0.6, 1.2, -0.5}) {
      RowMatrixXd first;
      for (int run = 0; run < 2; ++run) {
        Problem p(rig, 1, {Effector("tip", 2)});
        p.SetTarget(0, 0, Vec3(0, reach, 0));
        p.options.method = method;
        p.options.root_rotation = true;
        p.options.tolerance = 1e-6;
        p.options.max_iterations = method == IkMethod::kTranspose || method == IkMethod::kCcd ? 2000 : 64;
        p.Run();
        EXPECT_LT(p.errors(0, 0), 1e-6) << MethodName(method) << " reach " << reach;
        if (run == 0) {
          first = p.rotations;
        } else {
          EXPECT_EQ(first, p.rotations) << MethodName(method);
        }
      }
    }
  }
}

// Convergence rate: random 20-bone humanoids, random reachable targets for
// both hands with both feet pinned, hips free. DLS must meet all four to 1e-4
// of the rig's height in at least 99.5 % of 2,000 cases; the other methods'
// rates are printed for comparison.
TEST(IkConvergence, DlsMeetsRandomReachableFullBodyTargets) {
  const int cases = std::getenv("IKCASES") ? std::atoi(std::getenv("IKCASES")) : 2000;
  for (IkMethod method : kMethods) {
    std::mt19937 rng(2024);
    int met = 0;
    long iterations = 0;
    double worst_miss = 0.0;
    const auto start = std::chrono::steady_clock::now();
    for (int c = 0; c < cases; ++c) {
      const FullBody body(&rng);
      Problem p(body.rig, 1, body.Effectors());
      body.Reachable(p, 0, rng, 0.5);
      p.options.method = method;
      p.options.root_translation = true;
      p.options.root_rotation = true;
      p.options.tolerance = 1e-5 * body.Height();
      p.Run();
      const double miss = p.errors.row(0).maxCoeff() / body.Height();
      met += miss <= 1e-4;
      worst_miss = std::max(worst_miss, miss);
      iterations += p.iterations[0];
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double rate = 100.0 * met / cases;
    std::printf("[ IK rate  ] %-9s %6.2f %% of %d met to 1e-4 of the height; mean %.1f iterations; worst %.2e; %.1f us/solve\n",
                MethodName(method), rate, cases, static_cast<double>(iterations) / cases, worst_miss,
                1e6 * seconds / cases);
    if (method == IkMethod::kDls) {
      EXPECT_GE(rate, 99.5);
    }
  }
}

}  // namespace
}  // namespace motionkit
