// Packing keys for Blender's bulk F-curve write; the Blender-side comparison
// (this path against keyframe_points.insert) lives in
// tests/blender/bench_fcurve_write.py.
#include <benchmark/benchmark.h>

#include "motionkit/keyframes.hpp"

namespace {

void BM_KeyframeCo(benchmark::State& state) {
  const Eigen::Index curves = 100;
  const Eigen::Index keys = state.range(0);
  Eigen::VectorXd frames = Eigen::VectorXd::LinSpaced(keys, 1.0, static_cast<double>(keys));
  motionkit::RowMatrixXd values = motionkit::RowMatrixXd::Random(curves, keys);
  motionkit::RowMatrixXf co(curves, 2 * keys);
  for (auto _ : state) {
    motionkit::KeyframeCoJob job(frames, values, co);
    job.Run();
    benchmark::DoNotOptimize(co.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * curves * keys);
}
BENCHMARK(BM_KeyframeCo)->Arg(1000)->Arg(10000);

}  // namespace
