// Growing a carried (late) mask, as SlamSystem::maskFor does for every frame whose mask is older
// than the frame: dilateMaskLeavingFeatures gives the grown mask and, from the same distance map,
// the mask dilated by dynamic.mask_dilation_px alone (GrownMask::base_mask, which stage 1 uses to
// tell the grown ring). The baseline, measured in the same run, is the earlier way: the growth,
// then a second distance transform for the ungrown mask (dilateMask).
//   bench_mask_growth --benchmark_repetitions=5 --benchmark_report_aggregates_only
// BM_DilateMaskAlone is the second distance transform's own cost. Synthetic input (no data
// needed): a 640x480 mask with two walkers (ellipses) and 1000 keypoints spread over the image;
// the options' defaults (15 px dilation, a 3-frame-old mask grown by 36 px in steps of 12, 15 % of
// the keypoints kept outside). Measured on the 2-core build machine (6 Dec 2026, medians of 5):
// 1.3 ms with the base mask, 11 ms the earlier way, 1.3 ms the extra transform alone. Most of the
// earlier way's extra time there is page faults (160 000 against 2 000 over a second of
// iterations): a distance transform right after the growth has freed its buffers maps fresh
// memory. A whole run does not show that (300 Bonn crowd frames with emulated late masks: the same
// minor faults either way), so count on the 1.3 ms.
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dynamic/mask_utils.hpp"

namespace {

constexpr int kDilationPx = 15;
constexpr int kGrowthPx = 36;
constexpr int kGrowthStepPx = 12;
constexpr double kMinOutsideShare = 0.15;

cv::Mat walkersMask() {
  cv::Mat mask(480, 640, CV_8UC1, cv::Scalar(0));
  cv::ellipse(mask, cv::Point(200, 260), cv::Size(80, 200), 0, 0, 360, cv::Scalar(255), cv::FILLED);
  cv::ellipse(mask, cv::Point(460, 300), cv::Size(70, 180), 0, 0, 360, cv::Scalar(255), cv::FILLED);
  return mask;
}

std::vector<cv::KeyPoint> spreadKeypoints() {
  cv::RNG rng(7);
  std::vector<cv::KeyPoint> keypoints;
  for (int i = 0; i < 1000; ++i)
    keypoints.emplace_back(cv::Point2f(rng.uniform(0.f, 639.f), rng.uniform(0.f, 479.f)), 7.f);
  return keypoints;
}

void BM_GrowCarriedMaskWithBase(benchmark::State& state) {
  const cv::Mat mask = walkersMask();
  const std::vector<cv::KeyPoint> keypoints = spreadKeypoints();
  for (auto _ : state) {
    desslam::dynamic::GrownMask grown = desslam::dynamic::dilateMaskLeavingFeatures(
        mask, keypoints, kDilationPx, kGrowthPx, kGrowthStepPx, kMinOutsideShare);
    benchmark::DoNotOptimize(grown.mask.data);
    benchmark::DoNotOptimize(grown.base_mask.data);
  }
}
BENCHMARK(BM_GrowCarriedMaskWithBase)->Unit(benchmark::kMillisecond);

void BM_GrowCarriedMaskThenDilateAgain(benchmark::State& state) {  // the baseline
  const cv::Mat mask = walkersMask();
  const std::vector<cv::KeyPoint> keypoints = spreadKeypoints();
  for (auto _ : state) {
    desslam::dynamic::GrownMask grown = desslam::dynamic::dilateMaskLeavingFeatures(
        mask, keypoints, kDilationPx, kGrowthPx, kGrowthStepPx, kMinOutsideShare);
    cv::Mat ungrown = desslam::dynamic::dilateMask(mask, kDilationPx);
    benchmark::DoNotOptimize(grown.mask.data);
    benchmark::DoNotOptimize(ungrown.data);
  }
}
BENCHMARK(BM_GrowCarriedMaskThenDilateAgain)->Unit(benchmark::kMillisecond);

void BM_DilateMaskAlone(benchmark::State& state) {
  const cv::Mat mask = walkersMask();
  for (auto _ : state) {
    cv::Mat dilated = desslam::dynamic::dilateMask(mask, kDilationPx);
    benchmark::DoNotOptimize(dilated.data);
  }
}
BENCHMARK(BM_DilateMaskAlone)->Unit(benchmark::kMillisecond);
}  // namespace

BENCHMARK_MAIN();
