#include "dense/map_export.hpp"

#include <bit>
#include <cstring>
#include <fstream>

#include <octomap/OcTree.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/io/PointCloudIO.h>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace desslam::dense {
namespace {

namespace fs = std::filesystem;

// Open3D, OctoMap and OpenCV write by path: each writes a temporary file beside the target,
// which is fsynced and renamed onto it (core/atomic_file.hpp), so a failed export never leaves
// half a map. Failures throw OutputError naming the file and the reason.
void writeCloud(const fs::path& path, const open3d::geometry::PointCloud& cloud, const char* what) {
  const open3d::io::WritePointCloudOption binary(open3d::io::WritePointCloudOption::IsAscii::Binary,
                                                 open3d::io::WritePointCloudOption::Compressed::Uncompressed);
  writeFileAtomicallyVia(path, what, [&](const fs::path& tmp) {
    return open3d::io::WritePointCloud(tmp.string(), cloud, binary);
  });
}

void writeTree(const fs::path& path, octomap::OcTree& tree) {
  writeFileAtomicallyVia(path, "OctoMap", [&](const fs::path& tmp) { return tree.writeBinary(tmp.string()); });
}

}  // namespace

void writePly(const fs::path& path, const open3d::geometry::PointCloud& cloud) { writeCloud(path, cloud, "PLY"); }

void writePcd(const fs::path& path, const open3d::geometry::PointCloud& cloud) { writeCloud(path, cloud, "PCD"); }

std::shared_ptr<open3d::geometry::PointCloud> readPointCloud(const fs::path& path) {
  if (!fs::is_regular_file(path)) throw InputError("point cloud " + path.string() + " does not exist");
  auto cloud = std::make_shared<open3d::geometry::PointCloud>();
  if (!open3d::io::ReadPointCloud(path.string(), *cloud))
    throw InputError("cannot read point cloud " + path.string() + " (expected .ply, .pcd or .xyz)");
  return cloud;
}

namespace {
constexpr char kSourcesMagic[8] = {'D', 'S', 'S', 'R', 'C', 0, 0, 0};
constexpr uint32_t kSourcesVersion = 1;
static_assert(std::endian::native == std::endian::little, "map sidecar I/O assumes a little-endian host");
}  // namespace

void writeMapSources(const fs::path& path, const std::vector<Timestamp>& first_seen) {
  const uint32_t version = kSourcesVersion, reserved = 0;
  const uint64_t count = first_seen.size();
  std::string bytes;
  bytes.reserve(sizeof(kSourcesMagic) + 16 + count * sizeof(double));
  const auto put = [&bytes](const void* data, size_t n) { bytes.append(static_cast<const char*>(data), n); };
  put(kSourcesMagic, sizeof(kSourcesMagic));
  put(&version, sizeof(version));
  put(&reserved, sizeof(reserved));
  put(&count, sizeof(count));
  put(first_seen.data(), count * sizeof(double));
  writeFileAtomically(path, bytes, "map sidecar");
}

std::vector<Timestamp> readMapSources(const fs::path& path, std::optional<size_t> expected_count) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError("map sidecar " + path.string() +
                     " is missing: it is written by `desslam run` next to dense_map.ply; re-run to create it");
  char magic[8] = {};
  uint32_t version = 0, reserved = 0;
  uint64_t count = 0;
  in.read(magic, sizeof(magic));
  in.read(reinterpret_cast<char*>(&version), sizeof(version));
  in.read(reinterpret_cast<char*>(&reserved), sizeof(reserved));
  in.read(reinterpret_cast<char*>(&count), sizeof(count));
  if (!in || std::memcmp(magic, kSourcesMagic, sizeof(magic)) != 0)
    throw InputError(path.string() + " is not a dense-map sidecar (bad header); re-run `desslam run` to rewrite it");
  if (version != kSourcesVersion)
    throw InputError(path.string() + " has sidecar version " + std::to_string(version) + ", this program reads " +
                     std::to_string(kSourcesVersion) + "; re-run `desslam run` with this version");
  if (expected_count && count != *expected_count)
    throw InputError(path.string() + " lists " + std::to_string(count) + " points but the map has " +
                     std::to_string(*expected_count) +
                     ": the sidecar belongs to another dense_map.ply; re-run `desslam run` to write both together");
  std::vector<Timestamp> times(count);
  in.read(reinterpret_cast<char*>(times.data()), static_cast<std::streamsize>(count * sizeof(double)));
  if (in.gcount() != static_cast<std::streamsize>(count * sizeof(double)))
    throw InputError(path.string() + " is truncated (" + std::to_string(count) +
                     " times announced); re-run `desslam run` to rewrite it");
  return times;
}

void writeOctomap(const fs::path& path, const std::vector<WorldScan>& scans, double resolution, double max_range) {
  if (!(resolution > 0)) throw ConfigError("dense.octomap_resolution must be positive (metres)");
  octomap::OcTree tree(resolution);
  for (const WorldScan& scan : scans) {
    octomap::Pointcloud points;
    points.reserve(scan.points_w.size());
    for (const Vec3& p : scan.points_w)
      points.push_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    const octomap::point3d origin(static_cast<float>(scan.origin_w.x()), static_cast<float>(scan.origin_w.y()),
                                  static_cast<float>(scan.origin_w.z()));
    // discretize: one ray per end cell rather than per point; the clouds are already voxelised.
    // lazy_eval: inner nodes are brought up to date once at the end, not after every cell (the
    // leaves' log-odds are the same; writeBinary prunes either way).
    tree.insertPointCloud(points, origin, max_range > 0 ? max_range : -1.0, /*lazy_eval=*/true,
                          /*discretize=*/true);
  }
  tree.updateInnerOccupancy();
  writeTree(path, tree);
}

void writeOctomap(const fs::path& path, const open3d::geometry::PointCloud& cloud, double resolution) {
  if (!(resolution > 0)) throw ConfigError("dense.octomap_resolution must be positive (metres)");
  octomap::OcTree tree(resolution);
  for (const Eigen::Vector3d& p : cloud.points_)
    tree.updateNode(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()), true,
                    /*lazy_eval=*/true);
  tree.updateInnerOccupancy();
  writeTree(path, tree);
}

OctomapSummary readOctomap(const fs::path& path) {
  if (!fs::is_regular_file(path)) throw InputError("OctoMap file " + path.string() + " does not exist");
  octomap::OcTree tree(0.1);  // readBinary replaces the resolution with the file's
  if (!tree.readBinary(path.string()))
    throw InputError("cannot read OctoMap " + path.string() + ": not a binary OcTree (.bt) file");
  OctomapSummary summary;
  summary.resolution = tree.getResolution();
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    ++summary.leaves;
    const Vec3 centre(it.getX(), it.getY(), it.getZ());
    (tree.isNodeOccupied(*it) ? summary.occupied_centres : summary.free_centres).push_back(centre);
  }
  return summary;
}

void renderPng(const fs::path& path, const open3d::geometry::PointCloud& cloud, const std::vector<SE3>& camera_path,
               const RenderSettings& settings) {
  const cv::Mat image = renderMap(cloud, camera_path, settings);
  writeFileAtomicallyVia(path, "PNG", [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), image); });
}

}  // namespace desslam::dense
