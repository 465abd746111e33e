// Writing the dense map in the formats the field reads, and reading it back (tests, tools).
// Every writer writes atomically (core/atomic_file.hpp) and throws OutputError naming the file and
// the reason when it cannot be written.
#pragma once

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "core/se3.hpp"
#include "core/types.hpp"
#include "dense/dense_keyframe.hpp"
#include "dense/map_render.hpp"

namespace open3d::geometry {
class PointCloud;
}

namespace desslam::dense {

// Binary little-endian PLY with float xyz and uchar RGB (what MeshLab/CloudCompare open).
void writePly(const std::filesystem::path& path, const open3d::geometry::PointCloud& cloud);
// Binary PCD (PCL's format) with packed RGB.
void writePcd(const std::filesystem::path& path, const open3d::geometry::PointCloud& cloud);
// PLY/PCD/XYZ by extension; throws InputError when missing or unreadable.
std::shared_ptr<open3d::geometry::PointCloud> readPointCloud(const std::filesystem::path& path);

// Sidecar of an exported map (dense_map_sources.bin beside dense_map.ply): the first-seen time
// of every point, in the PLY's order, for the map check. Binary little-endian: 8-byte magic
// "DSSRC\0\0\0", uint32 version (1), uint32 reserved (0), uint64 count, count float64 times.
void writeMapSources(const std::filesystem::path& path, const std::vector<Timestamp>& first_seen);
// Throws InputError naming the file when it is missing, not a sidecar, of another version,
// truncated, or (expected_count given) holds a different number of times than the map has points.
std::vector<Timestamp> readMapSources(const std::filesystem::path& path,
                                      std::optional<size_t> expected_count = std::nullopt);

// OctoMap .bt with occupancy from RAY INSERTION: every keyframe cloud (DenseMap::worldScans) is
// inserted as a scan from its camera centre, so cells along each ray become free and cells at
// the points occupied; rays longer than max_range (metres, <= 0: no limit) mark free space only
// up to max_range. Dynamic pixels were left out of the scans, so people leave no occupied cells.
void writeOctomap(const std::filesystem::path& path, const std::vector<WorldScan>& scans, double resolution,
                  double max_range);
// The same, for exports that may take long: progress(share done, 0..1) is called at the start of
// each scan and then every 1024 rays (or 2^18 cells they cross) and 16384 cell updates, a few
// hundredths of a second of work at any resolution, and *abort (e.g. a signal handler's flag) is
// looked at right after each call; once it is true the insertion stops and nothing is written
// (returns false). Either may be null/empty. The file is byte for byte what
// octomap::OcTree::insertPointCloud (discretized, lazy) of each scan gives.
bool writeOctomap(const std::filesystem::path& path, const std::vector<WorldScan>& scans, double resolution,
                  double max_range, const std::atomic<bool>* abort, const std::function<void(double)>& progress);

// How much work ray insertion at `resolution` is, estimated from the scans before it starts: one
// ray per end cell (the points merged per cell), the cells the rays cross (ray_cells), the cell
// updates (per scan, the distinct cells its rays cross, estimated from how they fan out, plus its
// end cells: what the insertion's time grows with) and the cells of the box around every ray. The
// tree holds at most cells() = min(cell_updates, box_cells) leaves: what its memory grows with.
// fr1_xyz, 10 keyframes (the estimate is 1.1-2.3x the real count): 2.6e5 cells at 0.05 m
// (0.1 s), 1.9e7 at 0.01 m (10 s, 0.3 GiB), 5.6e7 at 0.005 m (60 s, 1.8 GiB); 1 keyframe at
// 0.001 m: 6e7 (200 s, 9 GiB: sparse rays cost ~130 bytes per cell).
struct OctomapCost {
  size_t rays = 0;
  double ray_cells = 0;
  double cell_updates = 0;
  double box_cells = 0;
  double cells() const { return std::min(cell_updates, box_cells); }
};
OctomapCost octomapCost(const std::vector<WorldScan>& scans, double resolution, double max_range);
// The resolution to write the OctoMap at: `resolution` when its cells() are at most max_cells,
// else the finest resolution * 2^k (k = 1, 2, ...) whose are.
double boundedOctomapResolution(const std::vector<WorldScan>& scans, double resolution, double max_range,
                                double max_cells);

// OctoMap .bt from the POINTS ALONE (e.g. the fused cloud): occupied cells only, no free space.
void writeOctomap(const std::filesystem::path& path, const open3d::geometry::PointCloud& cloud, double resolution);

struct OctomapSummary {
  double resolution = 0;
  size_t leaves = 0;
  std::vector<Vec3> occupied_centres;  // centres of occupied leaves (after pruning: any size)
  std::vector<Vec3> free_centres;
};
// Reads a .bt with octomap::OcTree; throws InputError when missing or not an OcTree file.
OctomapSummary readOctomap(const std::filesystem::path& path);

// renderMap() (map_render.hpp) written as PNG.
void renderPng(const std::filesystem::path& path, const open3d::geometry::PointCloud& cloud,
               const std::vector<SE3>& camera_path, const RenderSettings& settings = {});

}  // namespace desslam::dense
