// Pose-only optimisation and local BA on synthetic scenes (the sizes the tracking and mapping
// budgets are stated for). Run: build/bench/bench_optim --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include "optim/synthetic_scene.hpp"

namespace desslam::optim {
namespace {

// Tracking: ~600 matched map points, 70% with depth, 10% outliers, start 2 cm / 1 deg off.
void BM_OptimizePose(benchmark::State& state) {
  const auto cam = test::tumCamera();
  const test::PoseScene scene = test::makePoseScene(cam, static_cast<int>(state.range(0)), 0.7, 0.1, 42);
  std::mt19937 rng(1);
  const SE3 start = test::perturb(scene.T_c_w_true, rng, 0.02, M_PI / 180.0);
  for (auto _ : state) {
    std::vector<PoseObservation> observations = scene.observations;
    SE3 T_c_w = start;
    benchmark::DoNotOptimize(optimizePose(cam, T_c_w, observations));
  }
}
BENCHMARK(BM_OptimizePose)->Arg(300)->Arg(600)->Arg(800)->Unit(benchmark::kMillisecond);

// Local mapping: keyframes x points, 2% outliers, both passes.
void BM_BundleAdjust(benchmark::State& state) {
  const auto cam = test::tumCamera();
  const test::BaScene scene =
      test::makeBaScene(cam, static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), 0.02, 7);
  state.counters["observations"] = static_cast<double>(scene.observations.size());
  for (auto _ : state) {
    auto keyframes = scene.keyframes;
    auto points = scene.points;
    auto observations = scene.observations;
    benchmark::DoNotOptimize(bundleAdjust(cam, keyframes, points, observations));
  }
}
BENCHMARK(BM_BundleAdjust)->Args({10, 2000})->Args({15, 3000})->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace desslam::optim

BENCHMARK_MAIN();
