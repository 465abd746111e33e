// Dense mapping on rendered and real data: a synthetic room with a walking box (exact ground
// truth), and the fr1_xyz clip with ground-truth poses (set DESSLAM_DENSE_DEMO_DIR to keep the
// PLY, PNG and .bt it makes).
#include <cstdlib>
#include <filesystem>

#include <gtest/gtest.h>
#include <open3d/geometry/PointCloud.h>
#include <opencv2/imgproc.hpp>

#include "dense/dense_map.hpp"
#include "dense/map_check.hpp"
#include "dense/map_export.hpp"
#include "io/config.hpp"
#include "io/tum_dataset.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"
#include "support/shared_data.hpp"

namespace desslam::dense {
namespace {

TEST(DenseSyntheticRoom, FusedPointsLieOnStaticSurfacesAndNoneOnTheWalker) {
  sim::SceneOptions scene_options;
  scene_options.moving_object = true;
  const CameraOptions camera_options = sim::halfResolution(sim::syntheticCamera());
  const sim::SyntheticScene scene(scene_options, camera_options);
  const PinholeCamera camera(camera_options);
  const Trajectory path = sim::sweepPath(120, camera_options.fps);

  DenseOptions options;
  options.pixel_stride = 1;
  DenseMap masked(options, camera), unmasked(options, camera);
  std::vector<DenseKeyframe> keyframes;
  std::vector<Timestamp> times;
  size_t dynamic_pixels = 0;
  for (size_t i = 0; i < path.size(); i += 20) {
    const sim::RenderedFrame frame = scene.render(path[i].T_w_c, path[i].timestamp);
    DenseKeyframe kf{i, path[i].timestamp, frame.bgr, frame.depth, frame.dynamic_mask, {}, path[i].T_w_c};
    dynamic_pixels += static_cast<size_t>(cv::countNonZero(frame.dynamic_mask));
    masked.addKeyframe(kf);
    kf.exclude_mask = cv::Mat();
    unmasked.addKeyframe(kf);
    kf.exclude_mask = frame.dynamic_mask;
    keyframes.push_back(kf);
    times.push_back(path[i].timestamp);
  }
  ASSERT_GT(dynamic_pixels, 1000u) << "the walker should be in view for this test to mean anything";

  // On the walker at some keyframe time and not on a static surface (it stands on the floor).
  auto onWalkerOnly = [&](const Vec3& p) {
    if (scene.distanceToStaticSurface(p) < 0.01) return false;
    for (Timestamp t : times)
      if (scene.onMovingObject(p, t, 0.02)) return true;
    return false;
  };
  const auto cloud = masked.fuse();
  ASSERT_GT(cloud->points_.size(), 10000u);
  size_t off_surface = 0, on_walker = 0;
  for (const Eigen::Vector3d& p : cloud->points_) {
    off_surface += scene.distanceToStaticSurface(p) >= 0.01 ? 1 : 0;
    on_walker += onWalkerOnly(p) ? 1 : 0;
  }
  EXPECT_EQ(off_surface, 0u);
  EXPECT_EQ(on_walker, 0u);

  // Without the mask the walker is in the map, and later keyframes see through its ghosts.
  size_t unmasked_on_walker = 0;
  const auto unmasked_cloud = unmasked.fuse();  // a temporary shared_ptr would die before the loop
  for (const Eigen::Vector3d& p : unmasked_cloud->points_) unmasked_on_walker += onWalkerOnly(p) ? 1 : 0;
  EXPECT_GT(unmasked_on_walker, 100u);
  const MapCheckResult clean = freeSpaceViolations(masked.worldScans(), keyframes, camera);
  const MapCheckResult ghosts = freeSpaceViolations(unmasked.worldScans(), keyframes, camera);
  std::cout << "synthetic room: free-space violations with mask " << clean.violations << "/" << clean.checked
            << ", without " << ghosts.violations << "/" << ghosts.checked << "\n";
  // Exact depth and poses: only silhouette points, rounded to the neighbouring pixel, fail.
  EXPECT_LT(clean.share(), 0.01);
  EXPECT_GT(ghosts.violations, clean.violations + 100);
}

// Nearest ground-truth pose within 20 ms, as TUM's tools associate.
std::optional<SE3> poseAt(const Trajectory& gt, Timestamp t) {
  const auto it = std::lower_bound(gt.begin(), gt.end(), t,
                                   [](const StampedPose& p, Timestamp time) { return p.timestamp < time; });
  const StampedPose* best = nullptr;
  if (it != gt.end()) best = &*it;
  if (it != gt.begin() && (best == nullptr || t - std::prev(it)->timestamp < best->timestamp - t)) best = &*std::prev(it);
  if (best == nullptr || std::abs(best->timestamp - t) > 0.02) return std::nullopt;
  return best->T_w_c;
}

TEST(DenseFr1Xyz, GroundTruthPosesGiveAConsistentMap) {
  const auto clip = test::clipDir("fr1_xyz_0000_0099");
  DESSLAM_REQUIRE_SHARED(clip);
  const SystemOptions config = io::loadConfig(test::sourceDir() / "config" / "tum_fr1.yaml");
  const PinholeCamera camera(config.camera);
  const io::TumSequence sequence = io::TumSequence::open(clip);
  ASSERT_TRUE(sequence.groundTruth().has_value());

  DenseMap map(config.dense, camera);
  std::vector<DenseKeyframe> keyframes;
  std::vector<SE3> camera_path;
  for (size_t i = 0; i < sequence.size(); i += 10) {
    const io::RgbdImage image = sequence.load(i, config.camera);
    // The depth image is what gets mapped, so take the pose at ITS time: fr1 moves up to
    // ~60 deg/s, and the 15 ms between RGB and depth stamps already shows in the map check.
    const Timestamp depth_time = sequence.record(i).depth_timestamp;
    const auto pose = poseAt(*sequence.groundTruth(), depth_time);
    ASSERT_TRUE(pose.has_value()) << "no ground truth near " << depth_time;
    const DenseKeyframe kf{i, image.timestamp, image.bgr, image.depth, {}, {}, *pose};
    map.addKeyframe(kf);
    keyframes.push_back(kf);
    camera_path.push_back(*pose);
  }
  ASSERT_EQ(map.keyframeCount(), 10u);
  const auto cloud = map.fuse();
  EXPECT_GT(cloud->points_.size(), 50000u);
  // Real depth is noisy (Kinect: ~1-3 cm at 2-3 m) and fr1's depth stamps lag the motion
  // capture by ~30 ms, so even ground-truth poses leave a share of points that some later view
  // sees through; what the check must show is that wrong poses leave far more.
  const MapCheckResult check = freeSpaceViolations(map.worldScans(), keyframes, camera);
  PoseMap perturbed;
  for (size_t k = 0; k < keyframes.size(); ++k) {  // 5 cm and 3 degrees, alternating sides
    const double sign = k % 2 == 0 ? 1.0 : -1.0;
    const SE3 delta(Mat3(Eigen::AngleAxisd(sign * 3.0 * M_PI / 180, Vec3::UnitY())), Vec3(sign * 0.05, 0, 0));
    perturbed.emplace(keyframes[k].keyframe_id, keyframes[k].T_w_c * delta);
  }
  // The map a tracker with those pose errors would have made, checked against the true views.
  DenseMap wrong_map(config.dense, camera);
  for (DenseKeyframe kf : keyframes) {
    kf.T_w_c = perturbed.at(kf.keyframe_id);
    wrong_map.addKeyframe(kf);
  }
  const MapCheckResult wrong = freeSpaceViolations(wrong_map.worldScans(), keyframes, camera);
  std::cout << "fr1_xyz: " << map.voxelCount() << " stored voxels, " << cloud->points_.size() << " fused points; "
            << "free-space violations " << check.violations << "/" << check.checked << " = " << check.share()
            << " (perturbed poses: " << wrong.share() << ")\n";
  EXPECT_GT(check.checked, 100000u);
  EXPECT_LT(check.share(), 0.35);
  EXPECT_GT(wrong.share(), check.share() + 0.05);  // measured: 0.31 vs 0.37 (voxel map)

  RenderSettings settings;
  settings.width = config.dense.render_width;
  settings.height = config.dense.render_height;
  settings.point_size = config.dense.voxel_size;
  const cv::Mat image = renderMap(*cloud, camera_path, settings);
  cv::Mat grey;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  const double covered = cv::countNonZero(grey != grey.at<uint8_t>(0, 0)) / static_cast<double>(grey.total());
  // Measured 0.20 before free-space carving and 0.198 with it (carving leaves out depth noise that
  // later views see through): a good part of the picture either way.
  EXPECT_GT(covered, 0.15) << "the map should fill a good part of the picture";

  if (const char* out = std::getenv("DESSLAM_DENSE_DEMO_DIR"); out != nullptr && *out != '\0') {
    const std::filesystem::path dir(out);
    std::filesystem::create_directories(dir);
    writePly(dir / "fr1_xyz_map.ply", *cloud);
    renderPng(dir / "fr1_xyz_map.png", *cloud, camera_path, settings);
    writeOctomap(dir / "fr1_xyz_map.bt", map.worldScans(), config.dense.octomap_resolution, config.dense.max_depth);
    std::cout << "wrote " << dir / "fr1_xyz_map.{ply,png,bt}" << "\n";
  }
}

}  // namespace
}  // namespace desslam::dense
