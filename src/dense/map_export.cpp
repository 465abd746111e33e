#include "dense/map_export.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>
#include <utility>

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

namespace {

octomap::point3d toPoint(const Vec3& p) {
  return {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
}

// One ray per end cell ("discretize"; the clouds are already voxelised): a scan's points merged per
// cell of the tree, as the cells' centres in the order first seen.
std::vector<octomap::point3d> endCells(const octomap::OcTree& tree, const WorldScan& scan) {
  octomap::KeySet seen;
  std::vector<octomap::point3d> cells;
  for (const Vec3& p : scan.points_w) {
    const octomap::OcTreeKey key = tree.coordToKey(toPoint(p));
    if (seen.insert(key).second) cells.push_back(tree.keyToCoord(key));
  }
  return cells;
}

// A ray from the camera centre to an end cell, cut at max_range (<= 0: no limit): then it only
// marks free space and its end is not occupied.
struct Ray {
  octomap::point3d end;
  bool hits = true;  // ends at the end cell (occupied there)
};
Ray rayTo(const octomap::point3d& origin, const octomap::point3d& end, double max_range) {
  if (max_range <= 0 || (end - origin).norm() <= max_range) return {end, true};
  return {origin + (end - origin).normalized() * static_cast<float>(max_range), false};
}

// Cells a ray crosses from its origin's cell to (not including) its end cell: one per cell border,
// the sum of the key differences on the three axes.
double cellsCrossed(const octomap::OcTree& tree, const octomap::point3d& origin, const octomap::point3d& end) {
  const octomap::OcTreeKey a = tree.coordToKey(origin), b = tree.coordToKey(end);
  double cells = 0;
  for (unsigned axis = 0; axis < 3; ++axis) cells += std::abs(static_cast<double>(a[axis]) - static_cast<double>(b[axis]));
  return cells;
}

// Between two progress reports / abort checks (each at most a few hundredths of a second of work
// on the project's machine, at any resolution):
constexpr size_t kRaysPerCheck = 1024;       // rays,
constexpr size_t kCellsPerCheck = 1u << 18;  // or cells crossed by them (long rays at a fine resolution),
constexpr size_t kUpdatesPerCheck = 16384;   // and cell updates (up to ~3 us each in a sparse tree)

// The distinct cells one scan's rays cross, estimated. The rays fan out from the camera centre and
// share cells near it: at distance r they can be in no more cells than the area they cover there
// holds, their footprint (the solid angle of the 1-degree bins, on the plane 1 m along their mean
// direction, that hold a ray) times r^2. Per shell one cell thick, a ray crosses
// per_cell_of_length cells (ray_cells / (length / cell): more than 1 when it runs diagonally);
// spread as at random over the shell's cells, the rays' cells hit
// shell_cells (1 - exp(-their count / shell_cells)) distinct ones. At most the rays' cells.
double distinctRayCells(const std::vector<Vec3>& rays, double ray_cells, double resolution) {
  Vec3 sum = Vec3::Zero();
  for (const Vec3& ray : rays) sum += ray.normalized();
  const Vec3 mean = sum.norm() > 0 ? Vec3(sum.normalized()) : Vec3(rays.front().normalized());
  const Vec3 e1 = mean.unitOrthogonal(), e2 = mean.cross(e1);
  constexpr double kBin = M_PI / 180;
  std::set<std::pair<long, long>> bins;
  std::vector<double> lengths;  // metres, ascending
  double length_cells = 0;
  for (const Vec3& ray : rays) {
    const Vec3 d = ray.normalized();
    const double along = std::max(d.dot(mean), 0.05);  // (a camera sees less than +-87 degrees)
    bins.insert({std::lround(std::floor(d.dot(e1) / along / kBin)), std::lround(std::floor(d.dot(e2) / along / kBin))});
    lengths.push_back(ray.norm());
    length_cells += ray.norm() / resolution;
  }
  std::sort(lengths.begin(), lengths.end());
  const double solid_angle = static_cast<double>(bins.size()) * kBin * kBin;
  const double per_cell_of_length = length_cells > 0 ? std::max(1.0, ray_cells / length_cells) : 1.0;
  double distinct = 0;
  size_t shorter = 0;  // rays ending before the shell
  for (size_t shell = 0; shorter < lengths.size(); ++shell) {
    const double r = (static_cast<double>(shell) + 0.5) * resolution;
    while (shorter < lengths.size() && lengths[shorter] < r) ++shorter;
    const double reaching = static_cast<double>(lengths.size() - shorter);
    const double shell_cells = solid_angle * r * r / (resolution * resolution);
    distinct += shell_cells * -std::expm1(-per_cell_of_length * reaching / shell_cells);
  }
  return std::min(ray_cells, distinct);
}

}  // namespace

OctomapCost octomapCost(const std::vector<WorldScan>& scans, double resolution, double max_range) {
  if (!(resolution > 0)) throw ConfigError("dense.octomap_resolution must be positive (metres)");
  const octomap::OcTree tree(resolution);
  OctomapCost cost;
  Vec3 low = Vec3::Constant(std::numeric_limits<double>::infinity()), high = -low;  // of every ray
  for (const WorldScan& scan : scans) {
    const octomap::point3d origin = toPoint(scan.origin_w);
    std::vector<Vec3> rays;
    double ray_cells = 0;
    for (const octomap::point3d& end : endCells(tree, scan)) {
      const octomap::point3d cut = rayTo(origin, end, max_range).end;
      const Vec3 ray(cut.x() - origin.x(), cut.y() - origin.y(), cut.z() - origin.z());
      if (!(ray.norm() > 0)) continue;
      ray_cells += cellsCrossed(tree, origin, cut);
      rays.push_back(ray);
      low = low.cwiseMin(scan.origin_w + ray).cwiseMin(scan.origin_w);
      high = high.cwiseMax(scan.origin_w + ray).cwiseMax(scan.origin_w);
    }
    cost.rays += rays.size();
    cost.ray_cells += ray_cells;
    if (!rays.empty()) cost.cell_updates += distinctRayCells(rays, ray_cells, resolution) + static_cast<double>(rays.size());
  }
  if (cost.rays > 0) {
    cost.box_cells = 1;
    for (int axis = 0; axis < 3; ++axis) cost.box_cells *= std::floor((high[axis] - low[axis]) / resolution) + 2;
  }
  return cost;
}

double boundedOctomapResolution(const std::vector<WorldScan>& scans, double resolution, double max_range,
                                double max_cells) {
  double chosen = resolution;
  // Each doubling divides the cells by about 2 (sparse rays) to 8 (filled space).
  for (int k = 0; k < 30 && octomapCost(scans, chosen, max_range).cells() > max_cells; ++k) chosen *= 2;
  return chosen;
}

bool writeOctomap(const fs::path& path, const std::vector<WorldScan>& scans, double resolution, double max_range,
                  const std::atomic<bool>* abort, const std::function<void(double)>& progress) {
  if (!(resolution > 0)) throw ConfigError("dense.octomap_resolution must be positive (metres)");
  // Reports how far the insertion is (scan s, `within` of it) and says whether to stop.
  const auto stop = [&](size_t s, double within) {
    if (progress) progress(scans.empty() ? 1.0 : (static_cast<double>(s) + within) / static_cast<double>(scans.size()));
    return abort != nullptr && abort->load();
  };
  octomap::OcTree tree(resolution);
  octomap::KeyRay ray;
  // Each keyframe cloud is one scan from its camera centre: the cells its rays cross become free,
  // its end cells occupied (a cell that is both in one scan is occupied). lazy_eval: inner nodes
  // are brought up to date once at the end, not after every cell (the leaves' log-odds are the
  // same; writeBinary prunes either way). Each cell is updated once per scan, so the order of the
  // updates within a scan does not change the tree.
  for (size_t s = 0; s < scans.size(); ++s) {
    const octomap::point3d origin = toPoint(scans[s].origin_w);
    const std::vector<octomap::point3d> ends = endCells(tree, scans[s]);
    octomap::KeySet free_cells, occupied_cells;
    size_t rays_unchecked = 0, cells_unchecked = 0;
    for (size_t i = 0; i < ends.size(); ++i) {
      if (i == 0 || ++rays_unchecked >= kRaysPerCheck || cells_unchecked >= kCellsPerCheck) {
        if (stop(s, 0.5 * static_cast<double>(i) / static_cast<double>(ends.size()))) return false;
        rays_unchecked = cells_unchecked = 0;
      }
      const Ray r = rayTo(origin, ends[i], max_range);
      if (tree.computeRayKeys(origin, r.end, ray)) {
        free_cells.insert(ray.begin(), ray.end());
        cells_unchecked += ray.size();
      }
      octomap::OcTreeKey key;
      if (r.hits && tree.coordToKeyChecked(r.end, key)) occupied_cells.insert(key);
    }
    for (const octomap::OcTreeKey& key : occupied_cells) free_cells.erase(key);
    const double updates = static_cast<double>(free_cells.size() + occupied_cells.size());
    size_t done = 0;
    for (const octomap::KeySet* cells : {&free_cells, &occupied_cells}) {
      const bool occupied = cells == &occupied_cells;
      for (const octomap::OcTreeKey& key : *cells) {
        if (done++ % kUpdatesPerCheck == 0 && stop(s, 0.5 + 0.5 * static_cast<double>(done) / updates)) return false;
        tree.updateNode(key, occupied, /*lazy_eval=*/true);
      }
    }
  }
  if (stop(scans.size(), 0.0)) return false;
  tree.updateInnerOccupancy();
  writeTree(path, tree);
  return true;
}

void writeOctomap(const fs::path& path, const std::vector<WorldScan>& scans, double resolution, double max_range) {
  writeOctomap(path, scans, resolution, max_range, nullptr, {});
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
