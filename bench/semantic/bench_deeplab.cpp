// DeepLabV3-MobileNetV2 per-frame time (blob, forward, argmax, resize, mask) on 20 real frames
// (every 5th of ../shared/data/clips/bonn_crowd_0300_0399), with 1 OpenCV thread and with the
// default thread count. Each iteration segments the next frame in turn.
//   bench_deeplab --benchmark_repetitions=5 --benchmark_report_aggregates_only
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "semantic/deeplab_segmenter.hpp"

namespace {

namespace fs = std::filesystem;

fs::path sharedDir() {
  if (const char* env = std::getenv("DESSLAM_SHARED_DIR"); env != nullptr && *env != '\0') return env;
  return DESSLAM_DEFAULT_SHARED_DIR;
}

struct Frame {
  std::string name;
  cv::Mat bgr;
};

const std::vector<Frame>& benchFrames() {
  static const std::vector<Frame> frames = [] {
    std::vector<Frame> out;
    const fs::path rgb = sharedDir() / "data" / "clips" / "bonn_crowd_0300_0399" / "rgb";
    std::vector<fs::path> files;
    if (fs::is_directory(rgb))
      for (const auto& entry : fs::directory_iterator(rgb))
        if (entry.path().extension() == ".png") files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    for (std::size_t i = 0; i < files.size() && out.size() < 20; i += 5)
      out.push_back({files[i].filename().string(), cv::imread(files[i].string(), cv::IMREAD_COLOR)});
    if (out.empty())
      std::fprintf(stderr, "bench_deeplab: no frames under %s (set DESSLAM_SHARED_DIR)\n",
                   rgb.string().c_str());
    return out;
  }();
  return frames;
}

// The model is loaded once (hash check and parsing are not what is measured).
desslam::semantic::DeepLabSegmenter* segmenter() {
  static std::unique_ptr<desslam::semantic::DeepLabSegmenter> instance = []() {
    desslam::SemanticOptions options;
    if (options.model_path.empty())
      options.model_path = (sharedDir() / "models" / desslam::semantic::kDeepLabModelFile).string();
    try {
      return std::make_unique<desslam::semantic::DeepLabSegmenter>(options);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench_deeplab: %s\n", e.what());
      return std::unique_ptr<desslam::semantic::DeepLabSegmenter>();
    }
  }();
  return instance.get();
}

// state.range(0): OpenCV threads; 0 = OpenCV's default (all cores).
void BM_DeepLabSegment(benchmark::State& state) {
  const auto& frames = benchFrames();
  auto* net = segmenter();
  if (frames.empty() || net == nullptr) {
    state.SkipWithError("model or clip frames missing (see stderr)");
    return;
  }
  const int default_threads = cv::getNumThreads();
  if (state.range(0) > 0) cv::setNumThreads(int(state.range(0)));
  state.counters["threads"] = cv::getNumThreads();
  net->segment(frames[0].bgr, frames[0].name);  // warm-up: first forward allocates buffers
  std::size_t next = 0;
  double person_pixels = 0;
  for (auto _ : state) {
    const Frame& frame = frames[next++ % frames.size()];
    const auto result = net->segment(frame.bgr, frame.name);
    person_pixels += cv::countNonZero(result.dynamic_mask);
    benchmark::DoNotOptimize(result.dynamic_mask.data);
  }
  state.counters["person_share"] =
      person_pixels / (double(state.iterations()) * double(frames[0].bgr.total()));
  cv::setNumThreads(default_threads);
}
BENCHMARK(BM_DeepLabSegment)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->Iterations(20);

}  // namespace

BENCHMARK_MAIN();
