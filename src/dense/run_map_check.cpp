#include "dense/run_map_check.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <open3d/geometry/PointCloud.h>

#include "core/error.hpp"
#include "dense/map_export.hpp"
#include "io/trajectory_io.hpp"
#include "io/tum_dataset.hpp"

namespace desslam::dense {
namespace {

namespace fs = std::filesystem;

fs::path requireFile(const fs::path& path, const std::string& fix) {
  if (!fs::is_regular_file(path)) throw InputError(path.string() + " does not exist: " + fix);
  return path;
}

}  // namespace

RunMapCheckResult checkRunMap(const fs::path& out_dir, const fs::path& sequence_dir, const CameraOptions& camera_options,
                              const MapCheckOptions& options) {
  if (!fs::is_directory(out_dir))
    throw InputError("run folder " + out_dir.string() + " does not exist: pass the --out folder of `desslam run`");
  const std::string rerun = "re-run `desslam run <sequence> --config <yaml> --out " + out_dir.string() + "` to write it";
  const fs::path map_path = requireFile(out_dir / "dense_map.ply", rerun + " (with dense.enabled: true)");
  const fs::path sources_path = requireFile(out_dir / "dense_map_sources.bin", rerun);
  const fs::path keyframes_path = requireFile(out_dir / "KeyFrameTrajectory.txt", rerun);

  const PinholeCamera camera(camera_options);
  const auto cloud = readPointCloud(map_path);
  const std::vector<Timestamp> first_seen = readMapSources(sources_path, cloud->points_.size());
  const Trajectory keyframe_poses = io::readTumTrajectory(keyframes_path);
  const io::TumSequence sequence = io::TumSequence::open(sequence_dir);

  // Each keyframe's depth image: the pair whose RGB time is the keyframe's time.
  std::vector<DenseKeyframe> keyframes;
  keyframes.reserve(keyframe_poses.size());
  const auto& records = sequence.records();
  for (const StampedPose& pose : keyframe_poses) {
    const auto it = std::lower_bound(records.begin(), records.end(), pose.timestamp - 1e-4,
                                     [](const io::RgbdFrameRecord& r, double t) { return r.rgb_timestamp < t; });
    if (it == records.end() || std::abs(it->rgb_timestamp - pose.timestamp) > 1e-4)
      throw InputError("keyframe at time " + std::to_string(pose.timestamp) + " in " + keyframes_path.string() +
                       " has no RGB-D pair in " + sequence_dir.string() +
                       " (its depth image is missing, or this is not the run's sequence): pass the run's sequence "
                       "folder with all its depth images");
    const io::RgbdImage image = sequence.load(static_cast<size_t>(it - records.begin()), camera_options);
    DenseKeyframe kf;
    kf.keyframe_id = keyframes.size();
    kf.timestamp = pose.timestamp;
    kf.depth = image.depth;
    kf.T_w_c = pose.T_w_c;
    keyframes.push_back(std::move(kf));
  }

  RunMapCheckResult result;
  result.map_points = cloud->points_.size();
  result.keyframes = keyframes.size();
  result.check = freeSpaceViolations(cloud->points_, first_seen, keyframes, camera, options);
  return result;
}

}  // namespace desslam::dense
