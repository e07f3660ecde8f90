// The native part of retargeting a clip (retargeting issue): a 60-bone
// source rig and a 60-bone target rig of the same topology (hips, spine, neck
// and head, two arms with four three-bone fingers each, two legs, a tail),
// the target with other proportions, rest directions (arms 45 degrees down, a
// leaning spine, flat feet, curled fingers) and random rolls, every bone
// mapped. As in bench/retarget.py, which times the same job end to end in
// Blender.
//   BM_RetargetArmaturePose: ArmaturePoseJob on the source, pose channels
//     (smooth random rotations, root location) to armature-space
//     orientations and heads;
//   BM_RetargetJob: RetargetJob from those orientations to the target's pose
//     rotations and root location (validation included, as the add-on runs it).
// Items are bone-frames; ns_per_bone_frame is the figure to read.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "motionkit/retarget.hpp"
#include "motionkit/rig.hpp"
#include "rig_specs.hpp"

namespace {

using motionkit::RowMatrixXd;
using motionkit::test_rigs::BoneSpec;
using motionkit::test_rigs::MakeRig;

constexpr double kPi = 3.14159265358979323846;
constexpr int kBones = 60;

Eigen::Vector3d TurnDown(const Eigen::Vector3d& horizontal, double degrees) {
  const double a = -degrees * kPi / 180.0;
  return (horizontal.normalized() * std::cos(a) + Eigen::Vector3d::UnitZ() * std::sin(a)).normalized();
}

// 60 bones; the target differs in size, lengths, rest directions and rolls.
std::vector<BoneSpec> Humanoid(bool target) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> any(-kPi, kPi);
  const double size = target ? 1.15 : 1.0;
  std::vector<BoneSpec> bones;
  const auto chain = [&](const std::string& prefix, int parent, Eigen::Vector3d head,
                         const std::vector<Eigen::Vector3d>& directions, const std::vector<double>& lengths) {
    for (std::size_t i = 0; i < lengths.size(); ++i) {
      const Eigen::Vector3d tail = head + size * lengths[i] * directions[i].normalized();
      bones.push_back({prefix + std::to_string(i), parent, head, tail, target ? any(rng) : 0.0});
      parent = static_cast<int>(bones.size()) - 1;
      head = tail;
    }
    return parent;
  };
  const double lean = target ? 12.0 * kPi / 180.0 : 0.0;
  const Eigen::Vector3d up(0.0, -std::sin(lean), std::cos(lean));
  bones.push_back({"hips", -1, {0, 0, size}, {0, 0, 1.1 * size}, target ? any(rng) : 0.0});
  const std::vector<double> spine_lengths =
      target ? std::vector<double>{0.06, 0.07, 0.08, 0.08, 0.09, 0.10} : std::vector<double>(6, 0.08);
  const int chest = chain("spine", 0, {0, 0, 1.1 * size}, std::vector<Eigen::Vector3d>(6, up), spine_lengths);
  const Eigen::Vector3d top = bones.back().tail;
  const int neck = chain("neck", chest, top, std::vector<Eigen::Vector3d>(2, target ? Eigen::Vector3d(0, -0.3, 1) : up),
                         target ? std::vector<double>{0.06, 0.06} : std::vector<double>{0.05, 0.05});
  chain("head", neck, bones.back().tail, {up}, {target ? 0.22 : 0.2});
  for (const double sign : {1.0, -1.0}) {
    const std::string side = sign > 0 ? "L" : "R";
    const Eigen::Vector3d arm = TurnDown(Eigen::Vector3d(sign, 0, 0), target ? 45.0 : 0.0);
    const Eigen::Vector3d clavicle = target ? Eigen::Vector3d(sign, -0.3, 0.15) : Eigen::Vector3d(sign, 0, 0.1);
    const int hand = chain("arm" + side, chest, top + size * Eigen::Vector3d(sign * 0.03, 0, -0.04),
                           {clavicle, arm, arm, arm},
                           target ? std::vector<double>{0.16, 0.31, 0.29, 0.1} : std::vector<double>{0.15, 0.28, 0.26, 0.08});
    const Eigen::Vector3d hand_tail = bones.back().tail;
    for (int f = 0; f < 4; ++f) {
      const double spread = (f - 1.5) * 0.02;
      std::vector<Eigen::Vector3d> directions;
      for (int k = 0; k < 3; ++k) {
        directions.push_back((target ? TurnDown(arm, 20.0 * (k + 1)) : arm) + Eigen::Vector3d(0, spread, 0));
      }
      chain("finger" + side + std::to_string(f) + "_", hand, hand_tail + size * Eigen::Vector3d(0, spread, 0),
            directions, target ? std::vector<double>{0.035, 0.025, 0.02} : std::vector<double>(3, 0.03));
    }
    const Eigen::Vector3d leg = target ? Eigen::Vector3d(sign * 0.09, 0, -1) : Eigen::Vector3d(0, 0, -1);
    const Eigen::Vector3d foot = target ? Eigen::Vector3d(0, -1, 0) : Eigen::Vector3d(0, -0.8, -0.6);
    chain("leg" + side, 0, {sign * 0.1 * size, 0, size}, {leg, leg, foot, {0, -1, 0}},
          target ? std::vector<double>{0.47, 0.44, 0.12, 0.06} : std::vector<double>{0.45, 0.45, 0.1, 0.05});
  }
  std::vector<Eigen::Vector3d> tail;
  for (int k = 0; k < 10; ++k) tail.emplace_back(0, 1, (target ? 0.3 : -0.3) * k);
  chain("tail", 0, {0, 0.05 * size, size}, tail, std::vector<double>(10, target ? 0.06 : 0.05));
  return bones;
}

// The source's pose channels: per bone a random walk of its rotation vector
// (smooth, as bench/retarget.py makes them), the root's location a random walk.
struct Clip {
  RowMatrixXd basis, locations;
};

Clip SourceClip(int bones, Eigen::Index frames) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> step(0.0, 0.02);
  Clip clip{RowMatrixXd(frames, 4 * bones), RowMatrixXd::Zero(frames, 3 * bones)};
  for (int b = 0; b < bones; ++b) {
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    for (Eigen::Index f = 0; f < frames; ++f) {
      v += Eigen::Vector3d(step(rng), step(rng), step(rng));
      const double angle = v.norm();
      const Eigen::Quaterniond q =
          angle > 1e-12 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, v / angle)) : Eigen::Quaterniond::Identity();
      clip.basis.row(f).segment<4>(4 * b) << q.w(), q.x(), q.y(), q.z();
    }
  }
  Eigen::Vector3d root = Eigen::Vector3d::Zero();
  for (Eigen::Index f = 0; f < frames; ++f) {
    root += 0.5 * Eigen::Vector3d(step(rng), step(rng), step(rng));
    clip.locations.row(f).head<3>() = root.transpose();
  }
  return clip;
}

void Report(benchmark::State& state, Eigen::Index bones, Eigen::Index frames) {
  const auto bone_frames = static_cast<double>(bones * frames);
  state.SetItemsProcessed(state.iterations() * bones * frames);
  state.counters["bones"] = static_cast<double>(bones);
  state.counters["ns_per_bone_frame"] = benchmark::Counter(
      bone_frames, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void BM_RetargetArmaturePose(benchmark::State& state) {
  const motionkit::RigModel source = MakeRig(Humanoid(false));
  const Eigen::Index frames = state.range(0);
  const Clip clip = SourceClip(source.size(), frames);
  RowMatrixXd rotations(frames, 4 * source.size()), heads(frames, 3 * source.size());
  for (auto _ : state) {
    motionkit::ArmaturePoseJob job(source, clip.basis, clip.locations, rotations, heads);
    job.Run();
    benchmark::DoNotOptimize(rotations.data());
    benchmark::DoNotOptimize(heads.data());
    benchmark::ClobberMemory();
  }
  Report(state, source.size(), frames);
}
BENCHMARK(BM_RetargetArmaturePose)->Arg(10000)->Unit(benchmark::kMillisecond);

void BM_RetargetJob(benchmark::State& state) {
  const motionkit::RigModel source = MakeRig(Humanoid(false));
  const motionkit::RigModel target = MakeRig(Humanoid(true));
  if (source.size() != kBones || target.size() != kBones) {
    state.SkipWithError("the rigs do not have 60 bones");
    return;
  }
  const Eigen::Index frames = state.range(0);
  const Clip clip = SourceClip(source.size(), frames);
  RowMatrixXd source_rotations(frames, 4 * source.size()), source_heads(frames, 3 * source.size());
  motionkit::ArmaturePoseJob pose(source, clip.basis, clip.locations, source_rotations, source_heads);
  pose.Run();
  const RowMatrixXd root_heads = source_heads.leftCols(3);
  RowMatrixXd source_match(1, 4 * source.size()), target_match(1, 4 * target.size());
  for (int a = 0; a < source.size(); ++a) {
    const Eigen::Quaterniond q = source.rest(a);
    source_match.row(0).segment<4>(4 * a) << q.w(), q.x(), q.y(), q.z();
  }
  for (int b = 0; b < target.size(); ++b) target_match.row(0).segment<4>(4 * b) << 1, 0, 0, 0;
  std::vector<int> map;
  for (int b = 0; b < target.size(); ++b) map.push_back(b);  // same topology and order
  RowMatrixXd rotations(frames, 4 * target.size()), roots(frames, 3);
  for (auto _ : state) {
    motionkit::RetargetJob job(source, target, source_rotations, root_heads, source_match, target_match, rotations,
                               roots);
    job.bone_map = map;
    job.source_match_root = source.head(0);
    job.source_root = 0;
    job.target_root = 0;
    job.options.scale = target.head(0).z() / source.head(0).z();
    job.Run();
    benchmark::DoNotOptimize(rotations.data());
    benchmark::DoNotOptimize(roots.data());
    benchmark::ClobberMemory();
  }
  Report(state, target.size(), frames);
}
BENCHMARK(BM_RetargetJob)->Arg(10000)->Unit(benchmark::kMillisecond);

}  // namespace
