// Dense-map costs on the project's synthetic room (src/sim; no ../shared data needed):
//   BM_VoxelIndexVsUnorderedMap: the voxel map's key-index work (insert a room's voxels, look
//     every one up, move a fifth to neighbouring keys as a re-key does) with VoxelIndex and
//     with std::unordered_map in the same iteration; counter speedup = unordered_map / VoxelIndex.
//   BM_IntegrateWithLocalBaCorrections: 40 keyframes along the sweep path, each preceded by
//     corrections of the 10 previous poses by a few mm / 0.1 deg (what local BA sends), with
//     free-space carving; time per iteration / 40 = per keyframe (re-key + carve + merge).
//   build/bench/bench_dense_synthetic --benchmark_repetitions=3 --benchmark_report_aggregates_only
#include <ctime>
#include <random>
#include <unordered_map>

#include <benchmark/benchmark.h>

#include "dense/dense_map.hpp"
#include "dense/voxel_index.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"

namespace {

using namespace desslam;
using namespace desslam::dense;

struct Room {
  CameraOptions camera_options = sim::halfResolution(sim::syntheticCamera());
  std::vector<DenseKeyframe> keyframes;
};

const Room& room() {
  static const Room r = [] {
    Room out;
    const sim::SyntheticScene scene(sim::SceneOptions{}, out.camera_options);
    const Trajectory path = sim::sweepPath(240, out.camera_options.fps);
    for (size_t i = 0; i < path.size(); i += 6) {
      const sim::RenderedFrame frame = scene.render(path[i].T_w_c, path[i].timestamp);
      out.keyframes.push_back({i, path[i].timestamp, frame.bgr, frame.depth, {}, {}, path[i].T_w_c});
    }
    return out;
  }();
  return r;
}

// Voxel keys of the room as the dense map packs them (21 bits per axis).
std::vector<uint64_t> roomKeys() {
  const Room& r = room();
  DenseOptions options;
  options.pixel_stride = 1;
  const BackProjector project(options, PinholeCamera(r.camera_options));
  std::vector<uint64_t> keys;
  for (const DenseKeyframe& kf : r.keyframes) {
    const KeyframeCloud cloud = project(kf);
    for (const Eigen::Vector3f& p_c : cloud.points_c) {
      const Vec3 p = kf.T_w_c * p_c.cast<double>() / options.voxel_size;
      const auto axis = [](double v) { return static_cast<uint64_t>(static_cast<int64_t>(std::floor(v)) + (1 << 20)); };
      keys.push_back(axis(p.x()) | (axis(p.y()) << 21) | (axis(p.z()) << 42));
    }
  }
  return keys;
}

// CPU time of this thread: on a shared machine wall time mostly measures waiting for a core.
double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

template <class Index, class Insert, class Find, class Erase>
double indexWorkSeconds(const std::vector<uint64_t>& keys, Index& index, Insert insert, Find find, Erase erase) {
  const double start = threadCpuSeconds();
  uint32_t next = 0;
  for (uint64_t key : keys) insert(index, key, next++);
  size_t found = 0;
  for (uint64_t key : keys) found += find(index, key) ? 1 : 0;
  for (size_t i = 0; i < keys.size(); i += 5) {  // a re-key: out under the old key, in under a neighbour
    if (erase(index, keys[i])) insert(index, keys[i] + 1, static_cast<uint32_t>(i));
  }
  benchmark::DoNotOptimize(found);
  return threadCpuSeconds() - start;
}

void BM_VoxelIndexVsUnorderedMap(benchmark::State& state) {
  static const std::vector<uint64_t> keys = roomKeys();
  double flat_s = 0, node_s = 0;
  for (auto _ : state) {
    VoxelIndex flat;
    flat_s += indexWorkSeconds(
        keys, flat, [](VoxelIndex& m, uint64_t k, uint32_t v) { m.tryEmplace(k, v); },
        [](VoxelIndex& m, uint64_t k) { return m.find(k) != nullptr; }, [](VoxelIndex& m, uint64_t k) { return m.erase(k); });
    std::unordered_map<uint64_t, uint32_t> node;
    node_s += indexWorkSeconds(
        keys, node, [](auto& m, uint64_t k, uint32_t v) { m.try_emplace(k, v); },
        [](auto& m, uint64_t k) { return m.find(k) != m.end(); }, [](auto& m, uint64_t k) { return m.erase(k) == 1; });
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["keys"] = static_cast<double>(keys.size());
  state.counters["voxel_index_ms"] = 1e3 * flat_s / n;
  state.counters["unordered_map_ms"] = 1e3 * node_s / n;
  state.counters["speedup"] = flat_s > 0 ? node_s / flat_s : 0.0;
}
BENCHMARK(BM_VoxelIndexVsUnorderedMap)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_IntegrateWithLocalBaCorrections(benchmark::State& state) {
  const Room& r = room();
  const PinholeCamera camera(r.camera_options);
  DenseMapStats stats;
  for (auto _ : state) {
    DenseMap map(DenseOptions{}, camera);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> jitter(-1.0, 1.0);
    PoseMap poses;
    for (const DenseKeyframe& kf : r.keyframes) {
      PoseMap corrections;
      for (auto it = poses.rbegin(); it != poses.rend() && corrections.size() < 10; ++it) {
        const SE3 delta(Mat3(Eigen::AngleAxisd(0.1 * M_PI / 180 * jitter(rng), Vec3::UnitY())),
                        Vec3(0.004 * jitter(rng), 0.004 * jitter(rng), 0.004 * jitter(rng)));
        it->second = delta * it->second;
        corrections.emplace(it->first, it->second);
      }
      map.updatePoses(corrections);
      map.addKeyframe(kf);
      poses.emplace(kf.keyframe_id, kf.T_w_c);
    }
    stats = map.stats();
    benchmark::DoNotOptimize(stats);
  }
  state.counters["keyframes"] = static_cast<double>(r.keyframes.size());
  state.counters["voxels"] = static_cast<double>(stats.voxels);
  state.counters["rekeys"] = static_cast<double>(stats.rekeys);
  state.counters["voxels_rekeyed"] = static_cast<double>(stats.voxels_rekeyed);
  state.counters["voxel_misses"] = static_cast<double>(stats.voxel_misses);
}
BENCHMARK(BM_IntegrateWithLocalBaCorrections)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
