// BVH parse throughput on a generated clip: 31 joints (6 channels on the
// root, 3 on the others), 10,000 frames of random angles, written by WriteBvh
// so the numbers have the full shortest round-trip length (~18 characters).
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <string>

#include "motionkit/bvh.hpp"

namespace {

using motionkit::ChannelType;

motionkit::Skeleton SyntheticSkeleton(int joints) {
  motionkit::Skeleton skeleton;
  int column = 0;
  for (int i = 0; i < joints; ++i) {
    motionkit::Joint joint;
    joint.name = "joint" + std::to_string(i);
    // Five chains of six under the root, like limbs and a spine.
    joint.parent = i == 0 ? -1 : ((i - 1) % 6 == 0 ? 0 : i - 1);
    joint.offset = Eigen::Vector3d(0.0, 0.1 * i, 0.01);
    if (i == 0) {
      joint.channel_count = 6;
      joint.channels = {ChannelType::kXposition, ChannelType::kYposition, ChannelType::kZposition,
                        ChannelType::kZrotation, ChannelType::kXrotation, ChannelType::kYrotation};
    } else {
      joint.channel_count = 3;
      joint.channels = {ChannelType::kZrotation, ChannelType::kXrotation, ChannelType::kYrotation};
    }
    joint.first_channel = column;
    column += joint.channel_count;
    skeleton.joints.push_back(joint);
  }
  skeleton.channel_count = column;
  return skeleton;
}

std::string SyntheticClip(int frames) {
  const motionkit::Skeleton skeleton = SyntheticSkeleton(31);
  motionkit::Motion motion;
  motion.frame_time = 1.0 / 60.0;
  motion.values.resize(frames, skeleton.channel_count);
  std::mt19937_64 random(42);
  std::uniform_real_distribution<double> angle(-180.0, 180.0);
  for (Eigen::Index i = 0; i < motion.values.size(); ++i) motion.values.data()[i] = angle(random);
  return motionkit::WriteBvh(skeleton, motion);
}

void BM_ReadBvh(benchmark::State& state) {
  const std::string text = SyntheticClip(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    motionkit::Skeleton skeleton;
    motionkit::Motion motion;
    motionkit::ReadBvh(text, "bench.bvh", &skeleton, &motion);
    benchmark::DoNotOptimize(motion.values.data());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(text.size()));
  state.counters["file_MB"] = static_cast<double>(text.size()) / 1e6;
}
BENCHMARK(BM_ReadBvh)->Arg(10000)->Unit(benchmark::kMillisecond);

void BM_WriteBvh(benchmark::State& state) {
  const std::string text = SyntheticClip(static_cast<int>(state.range(0)));
  motionkit::Skeleton skeleton;
  motionkit::Motion motion;
  motionkit::ReadBvh(text, "bench.bvh", &skeleton, &motion);
  for (auto _ : state) {
    const std::string written = motionkit::WriteBvh(skeleton, motion);
    benchmark::DoNotOptimize(written.data());
  }
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(text.size()));
}
BENCHMARK(BM_WriteBvh)->Arg(10000)->Unit(benchmark::kMillisecond);

}  // namespace
