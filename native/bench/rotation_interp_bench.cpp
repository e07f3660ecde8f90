// Rotation interpolation and key reduction at clip scale (resampling issue).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>

#include "motionkit/key_reduction.hpp"
#include "motionkit/rotation_interpolation.hpp"

namespace {

// A smooth rotation sampled at unit steps from 0: one channel group's worth.
motionkit::RowMatrixXd SmoothQuaternions(Eigen::Index count, double step) {
  motionkit::RowMatrixXd q(count, 4);
  Eigen::Quaterniond previous = Eigen::Quaterniond::Identity();
  for (Eigen::Index i = 0; i < count; ++i) {
    const double t = static_cast<double>(i) * step;
    Eigen::Quaterniond r = Eigen::AngleAxisd(1.5 * std::sin(t / 31), Eigen::Vector3d::UnitZ()) *
                           Eigen::AngleAxisd(0.8 * std::sin(t / 17), Eigen::Vector3d::UnitX()) *
                           Eigen::AngleAxisd(2.0 * std::sin(t / 43), Eigen::Vector3d::UnitY());
    if (r.dot(previous) < 0) r.coeffs() = -r.coeffs();
    previous = r;
    q.row(i) << r.w(), r.x(), r.y(), r.z();
  }
  return q;
}

// range(0): 0 = rotations only, 1 = with angular velocity.
void BM_RotationInterpolate(benchmark::State& state) {
  const Eigen::Index keys = 10000, samples = 100000;
  const Eigen::VectorXd times = Eigen::VectorXd::LinSpaced(keys, 0.0, static_cast<double>(keys - 1));
  const motionkit::RowMatrixXd quats = SmoothQuaternions(keys, 1.0);
  const Eigen::VectorXd at = Eigen::VectorXd::LinSpaced(samples, 0.0, static_cast<double>(keys - 1));
  motionkit::RowMatrixXd out(samples, 4), omega(samples, 3);
  motionkit::RowMatrixXd no_omega(0, 3);
  for (auto _ : state) {
    motionkit::RotationInterpolateJob job(times, quats, at, out, state.range(0) ? omega : no_omega);
    job.options.kind = static_cast<motionkit::RotationInterpolant>(state.range(1));
    job.Run();
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * samples);
  state.SetLabel(motionkit::RotationInterpolantName(static_cast<motionkit::RotationInterpolant>(state.range(1))));
}
BENCHMARK(BM_RotationInterpolate)
    ->ArgNames({"omega", "kind"})
    ->Args({0, static_cast<int>(motionkit::RotationInterpolant::kSquad)})
    ->Args({1, static_cast<int>(motionkit::RotationInterpolant::kSquad)})
    ->Args({0, static_cast<int>(motionkit::RotationInterpolant::kSlerp)})
    ->Args({0, static_cast<int>(motionkit::RotationInterpolant::kCatmullRom)})
    ->Unit(benchmark::kMillisecond);

// 10,000 frames of one quaternion channel group sampled 4 times per frame.
void BM_ReduceQuaternionKeys(benchmark::State& state) {
  const Eigen::Index samples = 40000;
  const double tolerance = 1e-3 * static_cast<double>(state.range(0));  // radians
  const Eigen::VectorXd times = Eigen::VectorXd::LinSpaced(samples, 0.0, 0.25 * (samples - 1));
  const motionkit::RowMatrixXd quats = SmoothQuaternions(samples, 0.25);
  Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1> indices(samples);
  motionkit::RowMatrixXd in(samples, 4), out(samples, 4);
  Eigen::Index keys = 0;
  for (auto _ : state) {
    motionkit::KeyReductionJob job(times, quats, tolerance, indices, in, out);
    job.mode = motionkit::KeyToleranceMode::kQuaternion;
    job.Run();
    keys = job.key_count;
    benchmark::DoNotOptimize(indices.data());
  }
  state.SetItemsProcessed(state.iterations() * samples);
  state.counters["keys"] = static_cast<double>(keys);
}
BENCHMARK(BM_ReduceQuaternionKeys)->ArgName("mrad")->Arg(1)->Arg(10)->Unit(benchmark::kMillisecond);

}  // namespace
