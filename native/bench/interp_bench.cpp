// Keyframe resampling: many curves sampled at many sorted times, and the
// one-off cost of building a spline.
#include <benchmark/benchmark.h>

#include <random>

#include "motionkit/interpolation.hpp"

namespace {

using motionkit::Interpolant;

// Keys at jittered, strictly increasing times; random values.
void MakeKeys(Eigen::Index keys, unsigned seed, double* times, double* values) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(0.5, 1.5), value(-1.0, 1.0);
  double t = 0.0;
  for (Eigen::Index i = 0; i < keys; ++i) {
    times[i] = t;
    values[i] = value(rng);
    t += jitter(rng);
  }
}

// c curves x n keys each, sampled at m sorted times spanning all keys.
void BM_InterpolateCurves(benchmark::State& state, Interpolant kind) {
  const Eigen::Index curves = state.range(0), keys = state.range(1), samples = state.range(2);
  Eigen::VectorXi offsets(curves + 1);
  Eigen::VectorXd times(curves * keys), values(curves * keys), slopes(curves * keys);
  for (Eigen::Index c = 0; c <= curves; ++c) offsets[c] = static_cast<int>(c * keys);
  for (Eigen::Index c = 0; c < curves; ++c) {
    MakeKeys(keys, static_cast<unsigned>(c + 1), times.data() + c * keys, values.data() + c * keys);
  }
  slopes.setRandom();
  const Eigen::VectorXd eval = Eigen::VectorXd::LinSpaced(samples, -1.0, times[keys - 1] + 1.0);
  motionkit::RowMatrixXd out(curves, samples);
  motionkit::InterpolationOptions options;
  options.interpolant = kind;
  const Eigen::Map<const motionkit::RowMatrixXd> slope_view(slopes.data(), slopes.size(), 1);
  if (kind == Interpolant::kHermite) options.slopes.emplace(slope_view);
  motionkit::InterpolationScratch scratch;
  for (auto _ : state) {
    motionkit::InterpolateCurvesJob job(offsets, times, values, options, eval, out);
    job.scratch = &scratch;
    job.Run();
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  const double total = static_cast<double>(curves * samples);
  state.SetItemsProcessed(state.iterations() * curves * samples);
  state.counters["samples/s"] =
      benchmark::Counter(total, benchmark::Counter::kIsIterationInvariantRate);
}

void BM_InterpolateHermite(benchmark::State& state) { BM_InterpolateCurves(state, Interpolant::kHermite); }
BENCHMARK(BM_InterpolateHermite)->Args({100, 1000, 100000})->Unit(benchmark::kMillisecond);

void BM_InterpolateCatmullRom(benchmark::State& state) {
  BM_InterpolateCurves(state, Interpolant::kCatmullRom);
}
BENCHMARK(BM_InterpolateCatmullRom)->Args({100, 1000, 100000})->Unit(benchmark::kMillisecond);

// One location curve (d = 3) through the vector path, unsorted-capable job.
void BM_InterpolateCentripetal3d(benchmark::State& state) {
  const Eigen::Index keys = state.range(0), samples = state.range(1);
  Eigen::VectorXd times(keys), scratch_values(keys);
  MakeKeys(keys, 7, times.data(), scratch_values.data());
  const motionkit::RowMatrixXd values = motionkit::RowMatrixXd::Random(keys, 3);
  const Eigen::VectorXd eval = Eigen::VectorXd::LinSpaced(samples, 0.0, times[keys - 1]);
  motionkit::RowMatrixXd out(samples, 3);
  motionkit::InterpolationOptions options;
  options.interpolant = Interpolant::kCentripetalCatmullRom;
  motionkit::InterpolationScratch scratch;
  for (auto _ : state) {
    motionkit::InterpolateJob job(times, values, options, eval, out);
    job.scratch = &scratch;
    job.Run();
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * samples * 3);
}
BENCHMARK(BM_InterpolateCentripetal3d)->Args({1000, 100000})->Unit(benchmark::kMillisecond);

// Building a natural spline: the tridiagonal solve and the slopes.
void BM_NaturalSplineBuild(benchmark::State& state) {
  const Eigen::Index keys = state.range(0);
  Eigen::VectorXd times(keys);
  motionkit::RowMatrixXd values(keys, 1), slopes_in(keys, 1), slopes_out(keys, 1);
  MakeKeys(keys, 3, times.data(), values.data());
  motionkit::InterpolationOptions options;
  options.interpolant = Interpolant::kNaturalSpline;
  motionkit::InterpolationScratch scratch;
  for (auto _ : state) {
    motionkit::HermiteFormJob job(times, values, options, slopes_in, slopes_out);
    job.scratch = &scratch;
    job.Run();
    benchmark::DoNotOptimize(slopes_out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * keys);
}
BENCHMARK(BM_NaturalSplineBuild)->Arg(10000)->Unit(benchmark::kMicrosecond);

}  // namespace
