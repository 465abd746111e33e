// Our ORB extractor against cv::ORB (1000 features, 8 levels, scale 1.2) on a real 640x480 frame
// (first frame of ../shared/data/clips/fr1_xyz_0000_0099; a synthetic image when it is absent),
// plus the descriptor distance primitive.
//   bench_orb --benchmark_repetitions=5 --benchmark_report_aggregates_only
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "feature/descriptor.hpp"
#include "feature/orb_extractor.hpp"

namespace {

namespace fs = std::filesystem;

fs::path sharedDir() {
  if (const char* env = std::getenv("DESSLAM_SHARED_DIR"); env != nullptr && *env != '\0') return env;
  return DESSLAM_DEFAULT_SHARED_DIR;
}

cv::Mat syntheticFrame() {
  cv::RNG rng(1234);
  cv::Mat image(480, 640, CV_8U, cv::Scalar(128));
  for (int i = 0; i < 1500; ++i) {
    const int w = rng.uniform(8, 40), h = rng.uniform(8, 40);
    cv::rectangle(image, cv::Rect(rng.uniform(0, 640 - w), rng.uniform(0, 480 - h), w, h),
                  cv::Scalar(rng.uniform(0, 256)), cv::FILLED);
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  return image;
}

const cv::Mat& benchFrame() {
  static const cv::Mat frame = [] {
    const fs::path rgb = sharedDir() / "data" / "clips" / "fr1_xyz_0000_0099" / "rgb";
    std::vector<fs::path> files;
    if (fs::is_directory(rgb))
      for (const auto& entry : fs::directory_iterator(rgb))
        if (entry.path().extension() == ".png") files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    if (!files.empty()) {
      cv::Mat gray = cv::imread(files.front().string(), cv::IMREAD_GRAYSCALE);
      if (!gray.empty()) {
        std::fprintf(stderr, "bench_orb: frame %s\n", files.front().string().c_str());
        return gray;
      }
    }
    std::fprintf(stderr,
                 "bench_orb: real clip frame missing under %s (set DESSLAM_SHARED_DIR); using a synthetic "
                 "640x480 image instead\n",
                 rgb.string().c_str());
    return syntheticFrame();
  }();
  return frame;
}

void BM_DesslamOrbExtractor(benchmark::State& state) {
  const cv::Mat& gray = benchFrame();
  const desslam::feature::OrbExtractor extractor(desslam::OrbOptions{});
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  for (auto _ : state) {
    extractor.extract(gray, keypoints, descriptors);
    benchmark::DoNotOptimize(descriptors.data);
  }
  state.counters["keypoints"] = static_cast<double>(keypoints.size());
}
BENCHMARK(BM_DesslamOrbExtractor)->Unit(benchmark::kMillisecond);

void BM_OpenCvOrb(benchmark::State& state) {
  const cv::Mat& gray = benchFrame();
  const cv::Ptr<cv::ORB> orb = cv::ORB::create(1000, 1.2f, 8);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  for (auto _ : state) {
    orb->detectAndCompute(gray, cv::noArray(), keypoints, descriptors);
    benchmark::DoNotOptimize(descriptors.data);
  }
  state.counters["keypoints"] = static_cast<double>(keypoints.size());
}
BENCHMARK(BM_OpenCvOrb)->Unit(benchmark::kMillisecond);

// All-pairs distances between two sets of 1000 descriptors (one brute-force frame match).
void BM_DescriptorDistanceAllPairs(benchmark::State& state) {
  cv::Mat a(1000, 32, CV_8U), b(1000, 32, CV_8U);
  cv::randu(a, 0, 256);
  cv::randu(b, 0, 256);
  for (auto _ : state) {
    long sum = 0;
    for (int i = 0; i < a.rows; ++i)
      for (int j = 0; j < b.rows; ++j) sum += desslam::feature::descriptorDistance(a.ptr<uint8_t>(i), b.ptr<uint8_t>(j));
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * a.rows * b.rows);
}
BENCHMARK(BM_DescriptorDistanceAllPairs)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
