// DeepLabV3-MobileNetV2 per-frame time (input, forward, argmax, resize, mask) of both inference
// backends (semantic.backend = opencv | xnnpack) on the same 40 real frames: every 5th of
// ../shared/data/clips/bonn_crowd_0300_0399 and of fr1_xyz_0000_0099. Each iteration segments
// the next frame in turn.
//   BM_DeepLabSegment/<backend>/<threads>: 0 = opencv, 1 = xnnpack; threads for the network
//     (OpenCV: cv::setNumThreads; XNNPACK: the segmenter's pool, 1 = none).
//   BM_DeepLabBackendRatio/<threads>: both backends on each frame in turn, one thread count,
//     interleaved so that load from other processes hits both alike; counters opencv_ms,
//     xnnpack_ms and speedup (opencv / xnnpack) come from the same run.
//   bench_deeplab --benchmark_repetitions=5 --benchmark_report_aggregates_only
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "semantic/deeplab_common.hpp"
#include "semantic/segmenter.hpp"

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
    for (const char* clip : {"bonn_crowd_0300_0399", "fr1_xyz_0000_0099"}) {
      const fs::path rgb = sharedDir() / "data" / "clips" / clip / "rgb";
      std::vector<fs::path> files;
      if (fs::is_directory(rgb))
        for (const auto& entry : fs::directory_iterator(rgb))
          if (entry.path().extension() == ".png") files.push_back(entry.path());
      std::sort(files.begin(), files.end());
      std::size_t taken = 0;
      for (std::size_t i = 0; i < files.size() && taken < 20; i += 5, ++taken)
        out.push_back({files[i].filename().string(), cv::imread(files[i].string(), cv::IMREAD_COLOR)});
      if (taken == 0)
        std::fprintf(stderr, "bench_deeplab: no frames under %s (set DESSLAM_SHARED_DIR)\n",
                     rgb.string().c_str());
    }
    return out;
  }();
  return frames;
}

const char* backendName(std::int64_t index) { return index == 0 ? "opencv" : "xnnpack"; }

// One segmenter per (backend, threads), loaded once (hash check and parsing are not measured).
desslam::semantic::Segmenter* segmenter(const std::string& backend, int threads) {
  static std::map<std::pair<std::string, int>, std::unique_ptr<desslam::semantic::Segmenter>> cache;
  auto& slot = cache[{backend, threads}];
  if (!slot) {
    desslam::SemanticOptions options;
    options.backend = *desslam::enumFromName<desslam::SegmentationBackend>(backend);
    options.threads = threads;
    if (options.model_path.empty())
      options.model_path = (sharedDir() / "models" / desslam::semantic::kDeepLabModelFile).string();
    try {
      slot = desslam::semantic::makeSegmenter(options);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench_deeplab: %s\n", e.what());
      return nullptr;
    }
  }
  return slot.get();
}

// OpenCV's thread count is process-wide: set for the opencv backend, restored afterwards.
class OpenCvThreads {
 public:
  explicit OpenCvThreads(int threads) : saved_(cv::getNumThreads()) { cv::setNumThreads(threads); }
  ~OpenCvThreads() { cv::setNumThreads(saved_); }

 private:
  int saved_;
};

void BM_DeepLabSegment(benchmark::State& state) {
  const std::string backend = backendName(state.range(0));
  const int threads = int(state.range(1));
  const auto& frames = benchFrames();
  OpenCvThreads cv_threads(backend == "opencv" ? threads : 1);
  auto* net = segmenter(backend, threads);
  if (frames.empty() || net == nullptr) {
    state.SkipWithError("model or clip frames missing, or backend unavailable (see stderr)");
    return;
  }
  state.SetLabel(backend);
  state.counters["threads"] = threads;
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
}
BENCHMARK(BM_DeepLabSegment)
    ->ArgNames({"backend", "threads"})
    ->Args({0, 1})->Args({1, 1})->Args({0, 2})->Args({1, 2})
    ->Unit(benchmark::kMillisecond)->Iterations(40);

void BM_DeepLabBackendRatio(benchmark::State& state) {
  const int threads = int(state.range(0));
  const auto& frames = benchFrames();
  OpenCvThreads cv_threads(threads);
  auto* reference = segmenter("opencv", threads);
  auto* fast = segmenter("xnnpack", threads);
  if (frames.empty() || reference == nullptr || fast == nullptr) {
    state.SkipWithError("model or clip frames missing, or backend unavailable (see stderr)");
    return;
  }
  reference->segment(frames[0].bgr, frames[0].name);
  fast->segment(frames[0].bgr, frames[0].name);
  std::size_t next = 0;
  double reference_s = 0, fast_s = 0;
  for (auto _ : state) {
    const Frame& frame = frames[next++ % frames.size()];
    const auto a = reference->segment(frame.bgr, frame.name);
    const auto b = fast->segment(frame.bgr, frame.name);
    reference_s += a.seconds;
    fast_s += b.seconds;
    benchmark::DoNotOptimize(a.dynamic_mask.data);
    benchmark::DoNotOptimize(b.dynamic_mask.data);
  }
  const double n = double(state.iterations());
  state.counters["threads"] = threads;
  state.counters["opencv_ms"] = 1e3 * reference_s / n;
  state.counters["xnnpack_ms"] = 1e3 * fast_s / n;
  state.counters["speedup"] = fast_s > 0 ? reference_s / fast_s : 0.0;
}
BENCHMARK(BM_DeepLabBackendRatio)
    ->ArgName("threads")->Arg(1)->Arg(2)
    ->Unit(benchmark::kMillisecond)->Iterations(40);

}  // namespace

BENCHMARK_MAIN();
