// Whole-clip forward kinematics on a synthetic 31-joint humanoid: the root
// with six channels (positions, then Z X Y rotations), every other joint Z X Y
// rotations, random angles. The figure to watch is ns_per_joint_frame; the
// target is <= 10 ns. 10,000 frames is the reference clip (about 25 MB of
// input and output, so it also measures memory bandwidth); 100 frames stays
// in cache and shows the arithmetic alone. The Parallel variant cuts the clip
// between all the machine's threads (threads = 0).
#include <benchmark/benchmark.h>

#include <random>
#include <string>
#include <thread>

#include "bvh_fk.hpp"

namespace motionkit::internal {
// fk.cpp: false forces the baseline (SSE2) path on a machine with AVX2.
extern bool fk_allow_avx2;
}  // namespace motionkit::internal

namespace {

using motionkit::ChannelType;

motionkit::Skeleton Humanoid() {
  motionkit::Skeleton s;
  motionkit::Joint root;
  root.name = "Hips";
  root.channel_count = 6;
  root.channels = {ChannelType::kXposition, ChannelType::kYposition, ChannelType::kZposition,
                   ChannelType::kZrotation, ChannelType::kXrotation, ChannelType::kYrotation};
  s.joints.push_back(root);
  // Five chains of six from the root: spine and head, two arms, two legs.
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> offset(-10.0, 10.0);
  for (int chain = 0; chain < 5; ++chain) {
    for (int link = 0; link < 6; ++link) {
      motionkit::Joint joint;
      joint.name = "c" + std::to_string(chain) + "_" + std::to_string(link);
      joint.parent = link == 0 ? 0 : static_cast<int>(s.joints.size()) - 1;
      joint.offset = Eigen::Vector3d(offset(rng), offset(rng), offset(rng));
      joint.channel_count = 3;
      joint.channels[0] = ChannelType::kZrotation;
      joint.channels[1] = ChannelType::kXrotation;
      joint.channels[2] = ChannelType::kYrotation;
      s.joints.push_back(joint);
    }
  }
  for (motionkit::Joint& joint : s.joints) {
    joint.first_channel = s.channel_count;
    s.channel_count += joint.channel_count;
  }
  return s;
}

void SolveClips(benchmark::State& state, int threads) {
  const motionkit::Skeleton skeleton = Humanoid();
  const auto joints = static_cast<Eigen::Index>(skeleton.joints.size());
  const Eigen::Index frames = state.range(0);
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> angle(-180.0, 180.0);
  motionkit::RowMatrixXd values(frames, skeleton.channel_count);
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (Eigen::Index c = 0; c < values.cols(); ++c) values(f, c) = angle(rng);
  }
  motionkit::RowMatrixXd positions(frames, 3 * joints);
  motionkit::RowMatrixXd orientations(frames, 4 * joints);
  for (auto _ : state) {
    motionkit::ForwardKinematicsJob job(skeleton, values, positions, orientations);
    job.threads = threads;
    job.Run();
    benchmark::DoNotOptimize(positions.data());
    benchmark::DoNotOptimize(orientations.data());
    benchmark::ClobberMemory();
  }
  const auto joint_frames = static_cast<double>(joints * frames);
  state.SetItemsProcessed(state.iterations() * joints * frames);
  state.counters["joints"] = static_cast<double>(joints);
  state.counters["ns_per_joint_frame"] = benchmark::Counter(
      joint_frames, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void BM_ForwardKinematics(benchmark::State& state) { SolveClips(state, 1); }
BENCHMARK(BM_ForwardKinematics)->Arg(100)->Arg(10000)->Unit(benchmark::kMillisecond);

// Wall-clock time is what threads save, so it is what counts here.
void BM_ForwardKinematicsParallel(benchmark::State& state) {
  state.counters["threads"] = static_cast<double>(std::thread::hardware_concurrency());
  SolveClips(state, 0);
}
BENCHMARK(BM_ForwardKinematicsParallel)->Arg(10000)->Unit(benchmark::kMillisecond)->UseRealTime();

// The same without AVX2, as on a CPU that lacks it.
void BM_ForwardKinematicsBaseline(benchmark::State& state) {
  motionkit::internal::fk_allow_avx2 = false;
  BM_ForwardKinematics(state);
  motionkit::internal::fk_allow_avx2 = true;
}
BENCHMARK(BM_ForwardKinematicsBaseline)->Arg(10000)->Unit(benchmark::kMillisecond);

}  // namespace
