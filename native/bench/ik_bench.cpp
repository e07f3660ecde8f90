// Full-body IK over a clip: a 60-bone humanoid (a spine of seven, neck, head,
// jaw and eyes, arms with five three-bone fingers, legs with toes), both hands
// reaching for targets that move smoothly, both feet pinned, the hips free
// (root translation and rotation unknowns), every frame warm-started from the
// one before. 1,000 frames of a slow walk-like input animation; the hands'
// targets are where a second, smoothly animated pose puts them, so they are
// reachable. The figure to watch is time_per_frame for DLS (target <= 50 us);
// CCD, the Jacobian transpose and the pseudo-inverse run the same clip for
// comparison. iterations_per_frame is the mean; met is the fraction of frames
// whose four effectors all end within the tolerance (kTolerance).
//
// BM_IkDlsChains is the add-on's end-to-end case: the same rig, four position
// effectors (the hands with a chain of four bones, hand to clavicle; the feet
// with a chain of three, foot to thigh; every other bone excluded), no root
// unknowns, targets moving smoothly (where a second animated pose puts the
// four tips), 10,000 frames, DLS. The four chains share no unknown, so they
// are four independent problems (IkClipJob::Run), solved on 1 or 2 threads.
//   motionkit_bench --benchmark_filter=Ik --benchmark_repetitions=9 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "motionkit/ik.hpp"
#include "motionkit/rig.hpp"
#include "rig_specs.hpp"

namespace {

using motionkit::RowMatrixXd;
using motionkit::test_rigs::BoneSpec;
using motionkit::test_rigs::MakeRig;
using Vec3 = Eigen::Vector3d;
using Quat = Eigen::Quaterniond;

int Add(std::vector<BoneSpec>& b, const std::string& name, int parent, const Vec3& head, const Vec3& tail) {
  b.push_back({name, parent, head, tail});
  return static_cast<int>(b.size()) - 1;
}

std::vector<BoneSpec> Humanoid60() {
  std::vector<BoneSpec> b;
  int parent = Add(b, "hips", -1, {0, 0, 1.0}, {0, 0, 1.08});
  Vec3 at = b.back().tail;
  for (int i = 0; i < 7; ++i) {
    parent = Add(b, "spine" + std::to_string(i), parent, at, at + Vec3(0, 0.005 * (i % 2), 0.065));
    at = b.back().tail;
  }
  const int chest = parent;
  int neck = Add(b, "neck0", chest, at, at + Vec3(0, 0, 0.06));
  neck = Add(b, "neck1", neck, b.back().tail, b.back().tail + Vec3(0, 0, 0.06));
  const int head = Add(b, "head", neck, b.back().tail, b.back().tail + Vec3(0, 0, 0.2));
  const Vec3 skull = b[static_cast<std::size_t>(head)].head;
  Add(b, "jaw", head, skull + Vec3(0, -0.02, 0.03), skull + Vec3(0, -0.1, -0.01));
  Add(b, "eye_l", head, skull + Vec3(0.03, -0.08, 0.1), skull + Vec3(0.03, -0.1, 0.1));
  Add(b, "eye_r", head, skull + Vec3(-0.03, -0.08, 0.1), skull + Vec3(-0.03, -0.1, 0.1));
  for (const double side : {1.0, -1.0}) {
    const std::string s = side > 0 ? "_l" : "_r";
    const Vec3 shoulder(side * 0.18, 0, at.z() - 0.04);
    int p = Add(b, "clavicle" + s, chest, Vec3(side * 0.02, 0, at.z() - 0.04), shoulder);
    const Vec3 down(side * std::cos(0.6), 0, -std::sin(0.6));  // an A-pose
    const Vec3 elbow = shoulder + 0.3 * down, wrist = elbow + 0.26 * down;
    p = Add(b, "upper_arm" + s, p, shoulder, elbow);
    p = Add(b, "forearm" + s, p, elbow, wrist);
    const int hand = Add(b, "hand" + s, p, wrist, wrist + 0.08 * down);
    for (int finger = 0; finger < 5; ++finger) {
      Vec3 f = wrist + 0.08 * down + Vec3(0, -0.04 + 0.02 * finger, 0);
      int fp = hand;
      for (int k = 0; k < 3; ++k) {
        const Vec3 next = f + (0.035 - 0.008 * k) * down;
        fp = Add(b, "finger" + std::to_string(finger) + "_" + std::to_string(k) + s, fp, f, next);
        f = next;
      }
    }
  }
  for (const double side : {1.0, -1.0}) {
    const std::string s = side > 0 ? "_l" : "_r";
    int p = Add(b, "thigh" + s, 0, {side * 0.1, 0, 1.0}, {side * 0.1, -0.01, 0.54});
    p = Add(b, "shin" + s, p, {side * 0.1, -0.01, 0.54}, {side * 0.1, 0, 0.1});
    p = Add(b, "foot" + s, p, {side * 0.1, 0, 0.1}, {side * 0.1, -0.12, 0.03});
    Add(b, "toe" + s, p, {side * 0.1, -0.12, 0.03}, {side * 0.1, -0.18, 0.03});
  }
  return b;
}

Quat Turn(double x, double y, double z) {
  return Quat(Eigen::AngleAxisd(z, Vec3::UnitZ()) * Eigen::AngleAxisd(y, Vec3::UnitY()) *
              Eigen::AngleAxisd(x, Vec3::UnitX()));
}

void Store(RowMatrixXd& m, Eigen::Index f, int b, const Quat& q) {
  m.row(f).segment<4>(4 * b) << q.w(), q.x(), q.y(), q.z();
}

// The hands' tails under a pose (armature space), by plain FK.
Vec3 Tail(const motionkit::RigModel& rig, const RowMatrixXd& rotations, Eigen::Index f, const Vec3& location,
          int bone) {
  std::vector<Quat> g(static_cast<std::size_t>(rig.size()));
  std::vector<Vec3> h(static_cast<std::size_t>(rig.size()));
  for (int b = 0; b <= bone; ++b) {
    const Quat basis = motionkit::QuatAt(rotations, f, b).normalized();
    const int p = rig.parent(b);
    const auto i = static_cast<std::size_t>(b);
    if (p < 0) {
      g[i] = rig.relative(b) * basis;
      h[i] = rig.offset(b) + (b == 0 ? Vec3(rig.relative(b) * location) : Vec3::Zero());
    } else {
      const auto pi = static_cast<std::size_t>(p);
      g[i] = g[pi] * rig.relative(b) * basis;
      h[i] = h[pi] + g[pi] * rig.offset(b);
    }
  }
  const auto i = static_cast<std::size_t>(bone);
  return h[i] + g[i] * Vec3(0, rig.length(bone), 0);
}

struct Clip {
  motionkit::RigModel rig;
  std::vector<motionkit::IkEffector> effectors;
  std::vector<motionkit::IkJoint> joints;  // none: every bone free
  RowMatrixXd rotations, locations, targets, orientations;
  Clip() : rig(MakeRig(Humanoid60())) {
    const Eigen::Index frames = 1000;
    const int bones = rig.size();
    rotations = RowMatrixXd::Zero(frames, 4 * bones);
    locations = RowMatrixXd::Zero(frames, 3);
    targets = RowMatrixXd::Zero(frames, 12);
    orientations = RowMatrixXd::Zero(frames, 0);
    RowMatrixXd goal = RowMatrixXd::Zero(1, 4 * bones);
    const int hand_l = rig.Find("hand_l"), hand_r = rig.Find("hand_r");
    for (Eigen::Index f = 0; f < frames; ++f) {
      const double t = static_cast<double>(f) / 60.0;  // seconds at 60 fps
      // A slow walk-like input: every bone sways a little, the hips travel.
      for (int b = 0; b < bones; ++b) {
        const double phase = 0.7 * b;
        Store(rotations, f, b, Turn(0.15 * std::sin(2.0 * t + phase), 0.05 * std::sin(1.3 * t + phase),
                                    0.1 * std::sin(1.7 * t + 2 * phase)));
      }
      locations.row(f) << 0.02 * std::sin(t), 0.3 * t, 0.03 * std::sin(4 * t);
      // Where the hands should go: the same pose with spine and arms moved on.
      goal.row(0) = rotations.row(f);
      for (int b = 1; b < bones; ++b) {
        const std::string& n = rig.name(b);
        if (n.rfind("spine", 0) == 0 || n.rfind("clavicle", 0) == 0 || n.rfind("upper_arm", 0) == 0 ||
            n.rfind("forearm", 0) == 0) {
          Store(goal, 0, b, Turn(0.4 * std::sin(0.9 * t + b), 0.2 * std::cos(0.6 * t + b), 0.3 * std::sin(1.1 * t)));
        }
      }
      targets.row(f).segment<3>(0) = Tail(rig, goal, 0, locations.row(f).transpose(), hand_l).transpose();
      targets.row(f).segment<3>(3) = Tail(rig, goal, 0, locations.row(f).transpose(), hand_r).transpose();
    }
    for (const char* name : {"hand_l", "hand_r", "toe_l", "toe_r"}) {
      motionkit::IkEffector e;
      e.name = name;
      e.bone = rig.Find(name);
      e.pin = std::string(name).rfind("toe", 0) == 0;
      effectors.push_back(e);
    }
  }
};

const Clip& TheClip() {
  static const Clip clip;
  return clip;
}

// The chains case: hands (chain 4) and feet (chain 3) reach for where a
// second pose, with those chains' bones moved on, puts them.
struct ChainClip {
  motionkit::RigModel rig;
  std::vector<motionkit::IkEffector> effectors;
  std::vector<motionkit::IkJoint> joints;
  RowMatrixXd rotations, locations, targets, orientations;
  ChainClip() : rig(MakeRig(Humanoid60())) {
    const Eigen::Index frames = 10000;
    const int bones = rig.size();
    const std::vector<std::pair<const char*, int>> chains = {{"hand_l", 4}, {"hand_r", 4}, {"foot_l", 3}, {"foot_r", 3}};
    joints.assign(static_cast<std::size_t>(bones), motionkit::IkJoint{});
    for (motionkit::IkJoint& j : joints) j.excluded = true;
    std::vector<char> chain(static_cast<std::size_t>(bones), 0);
    for (const auto& [name, length] : chains) {
      int b = rig.Find(name);
      for (int k = 0; k < length && b >= 0; ++k, b = rig.parent(b)) {
        joints[static_cast<std::size_t>(b)].excluded = false;
        chain[static_cast<std::size_t>(b)] = 1;
      }
      motionkit::IkEffector e;
      e.name = name;
      e.bone = rig.Find(name);
      effectors.push_back(e);
    }
    rotations = RowMatrixXd::Zero(frames, 4 * bones);
    locations = RowMatrixXd::Zero(frames, 3);
    targets = RowMatrixXd::Zero(frames, 3 * static_cast<Eigen::Index>(chains.size()));
    orientations = RowMatrixXd::Zero(frames, 0);
    RowMatrixXd goal = RowMatrixXd::Zero(1, 4 * bones);
    for (Eigen::Index f = 0; f < frames; ++f) {
      const double t = static_cast<double>(f) / 60.0;
      for (int b = 0; b < bones; ++b) {
        const double phase = 0.7 * b;
        Store(rotations, f, b, Turn(0.15 * std::sin(2.0 * t + phase), 0.05 * std::sin(1.3 * t + phase),
                                    0.1 * std::sin(1.7 * t + 2 * phase)));
      }
      locations.row(f) << 0.02 * std::sin(t), 0.3 * t, 0.03 * std::sin(4 * t);
      goal.row(0) = rotations.row(f);
      for (int b = 0; b < bones; ++b) {
        if (chain[static_cast<std::size_t>(b)]) {
          Store(goal, 0, b, Turn(0.4 * std::sin(0.9 * t + b), 0.2 * std::cos(0.6 * t + b), 0.3 * std::sin(1.1 * t)));
        }
      }
      for (std::size_t e = 0; e < effectors.size(); ++e) {
        targets.row(f).segment<3>(3 * static_cast<Eigen::Index>(e)) =
            Tail(rig, goal, 0, locations.row(f).transpose(), effectors[e].bone).transpose();
      }
    }
  }
};

const ChainClip& TheChainClip() {
  static const ChainClip clip;
  return clip;
}

constexpr double kHeight = 1.65;
// What the default tolerance (3e-7 of the rig's size, its bounding box's diagonal) gives a person in
// a T pose.
constexpr double kTolerance = 0.7e-6;

// The clip's job in the benchmark loop; counters: time and iterations per
// frame, and the share of frames whose effectors all end within the tolerance.
template <class AnyClip>
void SolveClip(benchmark::State& state, const AnyClip& clip, const motionkit::IkOptions& options) {
  const Eigen::Index frames = clip.rotations.rows();
  const int bones = clip.rig.size();
  const auto count = static_cast<Eigen::Index>(clip.effectors.size());
  RowMatrixXd rotations(frames, 4 * bones), roots(frames, 3), scales(frames, bones), errors(frames, count);
  Eigen::VectorXi iterations(frames);
  for (auto _ : state) {
    motionkit::IkClipJob job(clip.rig, clip.rotations, clip.locations, clip.targets, clip.orientations, rotations,
                             roots, scales, errors, iterations);
    job.effectors = clip.effectors;
    job.joints = clip.joints;
    job.options = options;
    job.Run();
    benchmark::DoNotOptimize(rotations.data());
    benchmark::ClobberMemory();
  }
  int met = 0;
  for (Eigen::Index f = 0; f < frames; ++f) met += errors.row(f).maxCoeff() <= options.tolerance;
  state.counters["bones"] = bones;
  state.counters["time_per_frame"] = benchmark::Counter(
      static_cast<double>(frames), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["iterations_per_frame"] = static_cast<double>(iterations.sum()) / static_cast<double>(frames);
  state.counters["met"] = static_cast<double>(met) / static_cast<double>(frames);
}

void BM_IkDlsChains(benchmark::State& state) {
  motionkit::IkOptions options;
  options.method = motionkit::IkMethod::kDls;
  options.threads = static_cast<int>(state.range(0));
  options.tolerance = kTolerance;
  SolveClip(state, TheChainClip(), options);
}

void SolveClip(benchmark::State& state, motionkit::IkMethod method) {
  motionkit::IkOptions options;
  options.method = method;
  options.root_translation = true;
  options.root_rotation = true;
  options.tolerance = kTolerance;
  SolveClip(state, TheClip(), options);
}

void BM_IkDls(benchmark::State& state) { SolveClip(state, motionkit::IkMethod::kDls); }

// The same clip as a humanoid's natural defaults set it (test_rigs::NaturalJoints): the limbs first,
// the spine and the hips only while a hand is out of their reach, and balance over the pinned toes
// (masses: the bones' lengths).
struct NaturalClip : Clip {
  NaturalClip() { joints = motionkit::test_rigs::NaturalJoints(rig); }
};

void BM_IkDlsNatural(benchmark::State& state) {
  static const NaturalClip clip;
  SolveClip(state, clip, motionkit::test_rigs::NaturalOptions(kHeight));
}
BENCHMARK(BM_IkDlsNatural)->Unit(benchmark::kMillisecond);
void BM_IkCcd(benchmark::State& state) { SolveClip(state, motionkit::IkMethod::kCcd); }
void BM_IkTranspose(benchmark::State& state) { SolveClip(state, motionkit::IkMethod::kTranspose); }
void BM_IkPseudoInverse(benchmark::State& state) { SolveClip(state, motionkit::IkMethod::kPseudoInverse); }
BENCHMARK(BM_IkDls)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IkCcd)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IkTranspose)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IkPseudoInverse)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IkDlsChains)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace
