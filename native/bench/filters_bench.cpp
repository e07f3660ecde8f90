// Filters at clip scale: 10,000 frames of a 65-bone character, its locations
// (195 channels) and its rotations (65 quaternions, 260 channels).
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "motionkit/filters.hpp"

namespace {

constexpr Eigen::Index kFrames = 10000, kBones = 65;

// Smooth motion with a little noise, as a capture gives it.
motionkit::RowMatrixXd NoisyLocations() {
  std::mt19937 random(3);
  std::normal_distribution<double> noise(0.0, 0.002);
  motionkit::RowMatrixXd values(kFrames, 3 * kBones);
  for (Eigen::Index i = 0; i < kFrames; ++i) {
    for (Eigen::Index c = 0; c < values.cols(); ++c) {
      values(i, c) = std::sin(static_cast<double>(i) / (20.0 + static_cast<double>(c))) + noise(random);
    }
  }
  return values;
}

motionkit::RowMatrixXd NoisyRotations() {
  std::mt19937 random(4);
  std::normal_distribution<double> noise(0.0, 0.02);
  motionkit::RowMatrixXd q(kFrames, 4 * kBones);
  for (Eigen::Index i = 0; i < kFrames; ++i) {
    const double t = static_cast<double>(i);
    for (Eigen::Index b = 0; b < kBones; ++b) {
      const Eigen::Vector3d v(std::sin(t / (31.0 + static_cast<double>(b))) + noise(random),
                              0.5 * std::sin(t / 17.0) + noise(random), std::cos(t / 43.0) + noise(random));
      const Eigen::Quaterniond r(Eigen::AngleAxisd(v.norm(), v.normalized()));
      q.row(i).segment<4>(4 * b) << r.w(), r.x(), r.y(), r.z();
    }
  }
  return q;
}

motionkit::FilterSettings Butterworth() {
  motionkit::FilterSettings settings;
  settings.kind = motionkit::FilterKind::kButterworth;
  settings.fps = 30.0;
  return settings;
}

// range(0): threads (0: every core).
void BM_FilterChannelsButterworth(benchmark::State& state) {
  const motionkit::RowMatrixXd values = NoisyLocations();
  motionkit::RowMatrixXd out(values.rows(), values.cols());
  for (auto _ : state) {
    motionkit::FilterChannelsJob job(values, Butterworth(), out);
    job.threads = static_cast<int>(state.range(0));
    job.Run();
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * values.size());
}
BENCHMARK(BM_FilterChannelsButterworth)->ArgName("threads")->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);

void BM_FilterRotationsButterworth(benchmark::State& state) {
  const motionkit::RowMatrixXd q = NoisyRotations();
  motionkit::RowMatrixXd out(q.rows(), q.cols());
  for (auto _ : state) {
    motionkit::FilterRotationsJob job(q, Butterworth(), out);
    job.threads = static_cast<int>(state.range(0));
    job.Run();
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kFrames * kBones);
}
BENCHMARK(BM_FilterRotationsButterworth)->ArgName("threads")->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);

}  // namespace
