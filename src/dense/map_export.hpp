// Writing the dense map in the formats the field reads, and reading it back (tests, tools).
// Every writer writes atomically (core/atomic_file.hpp) and throws OutputError naming the file and
// the reason when it cannot be written.
#pragma once

#include <filesystem>
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
