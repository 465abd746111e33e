// Dense depth alignment (tracking/depth_alignment.hpp) on the rendered synthetic room.
#include <gtest/gtest.h>

#include <cmath>

#include "core/camera.hpp"
#include "core/error.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"
#include "tracking/depth_alignment.hpp"

namespace desslam::tracking {
namespace {

constexpr double kDeg = M_PI / 180.0;

double centreDistance(const SE3& a, const SE3& b) {
  return (a.inverse().translation() - b.inverse().translation()).norm();
}
double angleBetween(const SE3& a, const SE3& b) { return (a * b.inverse()).rotationAngle() / kDeg; }

struct Views {
  sim::RenderedFrame ref, cur;
  SE3 T_cur_ref;  // ground truth
};

Views render(const sim::SyntheticScene& scene, const SE3& T_w_ref, const SE3& T_w_cur, double t_ref, double t_cur) {
  return {scene.render(T_w_ref, t_ref), scene.render(T_w_cur, t_cur), T_w_cur.inverse() * T_w_ref};
}

// Aligns the current view to the reference one from no guess, with their masks or without.
DepthAlignmentResult alignViews(const DepthAligner& aligner, const Views& views, bool with_masks) {
  const cv::Mat none;
  return aligner.align(aligner.prepare(views.ref.depth, with_masks ? views.ref.dynamic_mask : none),
                       aligner.prepare(views.cur.depth, with_masks ? views.cur.dynamic_mask : none), SE3::identity());
}

// A camera looking into a corner of the room (walls, floor, furniture: every motion changes some
// depth), and one a step of a fast hand-held camera on (2 cm, 3 degrees). The sweep path's views
// see the far wall and the floor alone: sliding along both changes no depth.
std::pair<SE3, SE3> stepOfTheSweep() {
  const SE3 T_w_ref(sim::lookRotation(-45.0 * kDeg, -35.0 * kDeg, 0.0), Vec3(1.0, -0.5, 1.4));
  const SE3 step(Mat3(Eigen::AngleAxisd(2.0 * kDeg, Vec3(0, 1, 0)) * Eigen::AngleAxisd(2.0 * kDeg, Vec3(1, 0, 0))),
                 Vec3(0.015, -0.01, 0.008));
  return {T_w_ref, T_w_ref * step};
}

TEST(DepthAlignment, RecoversAStepOfAFastCameraFromNoGuess) {
  const CameraOptions camera_options = sim::syntheticCamera();
  const sim::SyntheticScene scene(sim::SceneOptions{}, camera_options);
  const PinholeCamera camera(camera_options);
  const auto [T_w_ref, T_w_cur] = stepOfTheSweep();
  const Views views = render(scene, T_w_ref, T_w_cur, 1000.0, 1000.0 + 1.0 / 30);
  const DepthAligner aligner(camera, DepthAlignmentOptions{});
  const DepthAlignmentResult r = alignViews(aligner, views, false);
  EXPECT_TRUE(r.accepted) << r.refusal;
  EXPECT_LT(centreDistance(r.T_cur_ref, views.T_cur_ref), 0.003);
  EXPECT_LT(angleBetween(r.T_cur_ref, views.T_cur_ref), 0.2);
  EXPECT_LT(r.rms_m, 0.002);
  EXPECT_GT(r.overlap, 0.8);
}

TEST(DepthAlignment, RecoversTheStepThroughALensDistortionAndDepthNoise) {
  CameraOptions camera_options = sim::syntheticCamera();
  camera_options.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};  // fr1's
  sim::SceneOptions scene_options;
  scene_options.depth_noise_sigma = 0.0015;  // Kinect-like: 1.5 mm at 1 m, 1.4 cm at 3 m
  const sim::SyntheticScene scene(scene_options, camera_options);
  const PinholeCamera camera(camera_options);
  const auto [T_w_ref, T_w_cur] = stepOfTheSweep();
  const Views views = render(scene, T_w_ref, T_w_cur, 1000.0, 1000.0 + 1.0 / 30);
  const DepthAlignmentOptions options;
  const DepthAligner aligner(camera, options);
  const DepthAlignmentResult r = alignViews(aligner, views, false);
  EXPECT_TRUE(r.accepted) << r.refusal;
  EXPECT_LT(centreDistance(r.T_cur_ref, views.T_cur_ref), 0.004);
  EXPECT_LT(angleBetween(r.T_cur_ref, views.T_cur_ref), 0.25);
}

// A person-sized box 1.5 m ahead, covering a third of the view, walks 2 cm towards the camera
// (0.6 m/s) between the two frames.
TEST(DepthAlignment, PixelsInEitherMaskAreLeftOut) {
  const CameraOptions camera_options = sim::syntheticCamera();
  sim::SceneOptions scene_options;
  scene_options.moving_object = true;
  const auto [T_w_ref, T_w_cur] = stepOfTheSweep();
  const Vec3 ahead = T_w_ref * Vec3(-0.4, 0, 1.5);
  scene_options.moving_start = {ahead.x(), ahead.y(), 0.0};
  const Vec3 towards_camera = T_w_ref.rotation() * Vec3(0, 0, -1);
  scene_options.moving_velocity = 0.6 * Vec3(towards_camera.x(), towards_camera.y(), 0.0).normalized();
  scene_options.moving_size = {0.5, 0.4, 1.8};
  scene_options.moving_t0 = 1000.0;
  const sim::SyntheticScene scene(scene_options, camera_options);
  const PinholeCamera camera(camera_options);
  const Views views = render(scene, T_w_ref, T_w_cur, 1000.0, 1000.0 + 1.0 / 30);
  const double covered = cv::countNonZero(views.cur.dynamic_mask) / static_cast<double>(views.cur.dynamic_mask.total());
  ASSERT_GT(covered, 0.2);  // the walker covers a good part of the view
  DepthAlignmentOptions options;
  options.min_constraint = 0;  // the walker hides part of the corner: this test is about the masks
  const DepthAligner aligner(camera, options);
  const DepthAlignmentResult masked = alignViews(aligner, views, true);
  EXPECT_TRUE(masked.accepted) << masked.refusal;
  EXPECT_LT(centreDistance(masked.T_cur_ref, views.T_cur_ref), 0.003);
  EXPECT_LT(angleBetween(masked.T_cur_ref, views.T_cur_ref), 0.2);
  const DepthAlignmentResult unmasked = alignViews(aligner, views, false);
  // Left in, the walker coming 2 cm closer pulls the estimate with him.
  EXPECT_GT(centreDistance(unmasked.T_cur_ref, views.T_cur_ref), 0.005);
  // The masked share is no part of the overlap: the usable pixels exclude it.
  const size_t finest = static_cast<size_t>(options.finest_level);
  const int usable_unmasked = aligner.prepare(views.cur.depth, cv::Mat()).levels[finest].usable;
  const int usable_masked = aligner.prepare(views.cur.depth, views.cur.dynamic_mask).levels[finest].usable;
  EXPECT_LT(usable_masked, (1.0 - 0.9 * covered) * usable_unmasked);
}

// The camera 0.8 m from a bare wall, looking at it: sliding along the wall, or turning about the
// optical axis, changes no depth. Such a view is refused, not given a made-up pose.
TEST(DepthAlignment, AViewOfOneWallIsRefused) {
  const CameraOptions camera_options = sim::syntheticCamera();
  sim::SceneOptions scene_options;
  scene_options.static_boxes = 0;
  const sim::SyntheticScene scene(scene_options, camera_options);
  const PinholeCamera camera(camera_options);
  const double far_wall_y = scene_options.room_size.y() / 2;
  const SE3 T_w_ref(sim::lookRotation(0, 0, 0), Vec3(0, far_wall_y - 0.8, 1.5));
  const SE3 T_w_cur = T_w_ref * SE3(Mat3::Identity(), Vec3(0.02, 0, 0));
  const Views views = render(scene, T_w_ref, T_w_cur, 1000.0, 1000.0 + 1.0 / 30);
  const DepthAlignmentOptions options;
  const DepthAligner aligner(camera, options);
  const DepthAlignmentResult r = alignViews(aligner, views, false);
  EXPECT_FALSE(r.accepted);
  EXPECT_LT(r.constraint, options.min_constraint);
  EXPECT_GT(r.overlap, 0.8);  // refused for the constraint, not for want of pairs
}

TEST(DepthAlignment, ImagesWithoutDepthAreRefused) {
  const CameraOptions camera_options = sim::syntheticCamera();
  const PinholeCamera camera(camera_options);
  const DepthAlignmentOptions options;
  const cv::Mat empty_depth(camera_options.height, camera_options.width, CV_32F, cv::Scalar(0));
  const DepthAligner aligner(camera, options);
  const DepthAlignmentResult r =
      aligner.align(aligner.prepare(empty_depth, cv::Mat()), aligner.prepare(empty_depth, cv::Mat()), SE3::identity());
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(r.correspondences, 0);
}

TEST(DepthAlignment, OptionsOutOfRangeAreRefusedByName) {
  DepthAlignmentOptions options;
  options.iterations = {};
  EXPECT_THROW(options.validate(), ConfigError);
  options = {};
  options.max_rms_m = 0;
  EXPECT_THROW(options.validate(), ConfigError);
  EXPECT_NO_THROW(DepthAlignmentOptions{}.validate());
}

}  // namespace
}  // namespace desslam::tracking
