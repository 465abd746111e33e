// Dense mapping costs on the fr1_xyz clip (10 keyframes, ground-truth poses at depth time):
// per-keyframe back-projection (+ downsampling), integration into the voxel map, export with
// outlier removal, the free-space check, and the exports. Needs ../shared (DESSLAM_SHARED_DIR overrides the built-in default).
//   build/bench/bench_dense --benchmark_repetitions=5 --benchmark_report_aggregates_only
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include <benchmark/benchmark.h>
#include <open3d/geometry/PointCloud.h>

#include "dense/dense_map.hpp"
#include "dense/map_check.hpp"
#include "dense/map_export.hpp"
#include "io/config.hpp"
#include "io/tum_dataset.hpp"

namespace {

using namespace desslam;
using namespace desslam::dense;

struct Fixture {
  SystemOptions config;
  std::unique_ptr<PinholeCamera> camera;
  std::vector<DenseKeyframe> keyframes;
};

std::filesystem::path sharedDir() {
  const char* env = std::getenv("DESSLAM_SHARED_DIR");
  return env != nullptr && *env != '\0' ? std::filesystem::path(env) : std::filesystem::path(DESSLAM_DEFAULT_SHARED_DIR);
}

SE3 nearestPose(const Trajectory& gt, Timestamp t) {
  const StampedPose* best = &gt.front();
  for (const StampedPose& p : gt)
    if (std::abs(p.timestamp - t) < std::abs(best->timestamp - t)) best = &p;
  return best->T_w_c;
}

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture out;
    const auto source = std::filesystem::path(__FILE__).parent_path().parent_path().parent_path();
    out.config = io::loadConfig(source / "config" / "tum_fr1.yaml");
    out.camera = std::make_unique<PinholeCamera>(out.config.camera);
    const auto sequence = io::TumSequence::open(sharedDir() / "data" / "clips" / "fr1_xyz_0000_0099");
    for (size_t i = 0; i < sequence.size(); i += 10) {
      const io::RgbdImage image = sequence.load(i, out.config.camera);
      const SE3 pose = nearestPose(*sequence.groundTruth(), sequence.record(i).depth_timestamp);
      out.keyframes.push_back({i, image.timestamp, image.bgr, image.depth, {}, {}, pose});
    }
    return out;
  }();
  return f;
}

void BM_BackProjectAndDownsample(benchmark::State& state) {
  const Fixture& f = fixture();
  DenseOptions options = f.config.dense;
  options.pixel_stride = static_cast<int>(state.range(0));
  const BackProjector project(options, *f.camera);
  size_t points = 0;
  for (auto _ : state) {
    const KeyframeCloud cloud = voxelDownsample(project(f.keyframes[0]), options.voxel_size);
    points = cloud.size();
    benchmark::DoNotOptimize(points);
  }
  state.counters["points"] = static_cast<double>(points);
}
BENCHMARK(BM_BackProjectAndDownsample)->Arg(1)->Arg(2)->Arg(4)->Unit(benchmark::kMillisecond);

DenseMap buildMap() {
  const Fixture& f = fixture();
  DenseMap map(f.config.dense, *f.camera);
  for (const DenseKeyframe& kf : f.keyframes) map.addKeyframe(kf);
  return map;
}

// Back-projection and merging into the voxel map of all 10 keyframes (time / 10 = per keyframe).
void BM_Integrate10Keyframes(benchmark::State& state) {
  size_t voxels = 0;
  for (auto _ : state) {
    voxels = buildMap().voxelCount();
    benchmark::DoNotOptimize(voxels);
  }
  state.counters["voxels"] = static_cast<double>(voxels);
}
BENCHMARK(BM_Integrate10Keyframes)->Unit(benchmark::kMillisecond);

void BM_Fuse10Keyframes(benchmark::State& state) {
  const DenseMap map = buildMap();
  size_t points = 0;
  for (auto _ : state) {
    points = map.fuse()->points_.size();
    benchmark::DoNotOptimize(points);
  }
  state.counters["voxels"] = static_cast<double>(map.voxelCount());
  state.counters["fused"] = static_cast<double>(points);
}
BENCHMARK(BM_Fuse10Keyframes)->Unit(benchmark::kMillisecond);

void BM_FreeSpaceCheck10Keyframes(benchmark::State& state) {
  const DenseMap map = buildMap();
  const auto scans = map.worldScans();
  MapCheckResult result;
  for (auto _ : state) {
    result = freeSpaceViolations(scans, fixture().keyframes, *fixture().camera);
    benchmark::DoNotOptimize(result);
  }
  state.counters["checked"] = static_cast<double>(result.checked);
  state.counters["share"] = result.share();
}
BENCHMARK(BM_FreeSpaceCheck10Keyframes)->Unit(benchmark::kMillisecond);

void BM_WriteOctomapRays(benchmark::State& state) {
  const DenseMap map = buildMap();
  const auto scans = map.worldScans();
  const auto path = std::filesystem::temp_directory_path() / "bench_dense_map.bt";
  for (auto _ : state) writeOctomap(path, scans, fixture().config.dense.octomap_resolution, fixture().config.dense.max_depth);
  std::filesystem::remove(path);
}
BENCHMARK(BM_WriteOctomapRays)->Unit(benchmark::kMillisecond);

void BM_RenderPreview(benchmark::State& state) {
  const auto cloud = buildMap().fuse();
  std::vector<SE3> path;
  for (const DenseKeyframe& kf : fixture().keyframes) path.push_back(kf.T_w_c);
  for (auto _ : state) benchmark::DoNotOptimize(renderMap(*cloud, path).data);
}
BENCHMARK(BM_RenderPreview)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
