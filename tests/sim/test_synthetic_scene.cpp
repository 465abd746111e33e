#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/camera.hpp"
#include "core/error.hpp"
#include "sim/synthetic_scene.hpp"

namespace desslam::sim {
namespace {

SceneOptions sceneWithMover() {
  SceneOptions options;
  options.moving_object = true;
  return options;
}

Vec3 worldPoint(const PinholeCamera& camera, const SE3& T_w_c, int u, int v, float depth) {
  return T_w_c * camera.backProject(Vec2(u, v), depth);
}

TEST(SyntheticScene, DepthBackProjectsOntoStaticSurfaceOrMover) {
  const CameraOptions camera_options = syntheticCamera();
  const SyntheticScene scene(sceneWithMover(), camera_options);
  const PinholeCamera camera(camera_options);
  const Trajectory path = sweepPath(90, 30.0);
  for (int i : {0, 45, 89}) {
    const auto& pose = path[i];
    const RenderedFrame frame = scene.render(pose.T_w_c, pose.timestamp);
    int static_pixels = 0, far_from_static = 0, mover_pixels = 0, off_mover = 0;
    for (int v = 0; v < frame.depth.rows; ++v) {
      for (int u = 0; u < frame.depth.cols; ++u) {
        const float z = frame.depth.at<float>(v, u);
        ASSERT_GT(z, 0.0f);
        const Vec3 p = worldPoint(camera, pose.T_w_c, u, v, z);
        if (frame.dynamic_mask.at<uchar>(v, u) == 0) {
          ++static_pixels;
          if (scene.distanceToStaticSurface(p) >= 1e-3) ++far_from_static;
        } else {
          ++mover_pixels;
          if (!scene.onMovingObject(p, pose.timestamp, 1e-3)) ++off_mover;
        }
      }
    }
    EXPECT_GT(static_pixels, 100000) << "frame " << i;
    EXPECT_EQ(far_from_static, 0) << "frame " << i;
    EXPECT_EQ(off_mover, 0) << "frame " << i;
    // The default mover is meant to be in view during the first seconds of the default paths.
    EXPECT_GT(mover_pixels, 5000) << "frame " << i;
  }
}

TEST(SyntheticScene, MaskEqualsPixelsOnMovingObject) {
  const CameraOptions camera_options = syntheticCamera();
  const SyntheticScene scene(sceneWithMover(), camera_options);
  const PinholeCamera camera(camera_options);
  const Trajectory path = sweepPath(60, 30.0);
  for (int i : {10, 50}) {
    const auto& pose = path[i];
    const RenderedFrame frame = scene.render(pose.T_w_c, pose.timestamp);
    int masked = 0, mismatches = 0;
    for (int v = 0; v < frame.depth.rows; ++v) {
      for (int u = 0; u < frame.depth.cols; ++u) {
        const Vec3 p = worldPoint(camera, pose.T_w_c, u, v, frame.depth.at<float>(v, u));
        const bool in_mask = frame.dynamic_mask.at<uchar>(v, u) == 255;
        masked += in_mask;
        // A tight tolerance: floor points right at the mover's feet must not count.
        if (in_mask != scene.onMovingObject(p, pose.timestamp, 1e-5)) ++mismatches;
      }
    }
    EXPECT_GT(masked, 5000) << "frame " << i;
    EXPECT_EQ(mismatches, 0) << "frame " << i;
  }
}

TEST(SyntheticScene, MoverMovesAndStaysInTheRoom) {
  const SyntheticScene scene(sceneWithMover(), syntheticCamera());
  const SceneOptions& o = scene.options();
  const auto start = scene.movingObjectBox(o.moving_t0);
  EXPECT_NEAR(start.center().x(), o.moving_start.x(), 1e-12);
  const auto later = scene.movingObjectBox(o.moving_t0 + 1.0);
  EXPECT_NEAR((later.center() - start.center()).norm(), o.moving_velocity.norm(), 1e-9);
  const Eigen::AlignedBox3d room(Vec3(-3, -2, 0), Vec3(3, 2, 3));
  for (double t = o.moving_t0 - 50; t < o.moving_t0 + 50; t += 0.37) EXPECT_TRUE(room.contains(scene.movingObjectBox(t)));
  EXPECT_FALSE(scene.onMovingObject(start.center() + Vec3(0, 0, 5), o.moving_t0));
  EXPECT_TRUE(scene.onMovingObject(start.center(), o.moving_t0));

  const SyntheticScene still(SceneOptions{}, syntheticCamera());
  EXPECT_FALSE(still.onMovingObject(start.center(), o.moving_t0));
  EXPECT_TRUE(still.movingObjectBox(o.moving_t0).isEmpty());
}

TEST(SyntheticScene, RendersAreDeterministic) {
  SceneOptions options = sceneWithMover();
  options.depth_noise_sigma = 0.005;
  const SyntheticScene scene(options, syntheticCamera());
  const auto pose = sweepPath(20, 30.0)[19];
  const RenderedFrame a = scene.render(pose.T_w_c, pose.timestamp);
  const RenderedFrame b = scene.render(pose.T_w_c, pose.timestamp);
  EXPECT_EQ(cv::norm(a.bgr, b.bgr, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.depth, b.depth, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.dynamic_mask, b.dynamic_mask, cv::NORM_INF), 0.0);
  // A second scene with the same options is the same scene.
  const RenderedFrame c = SyntheticScene(options, syntheticCamera()).render(pose.T_w_c, pose.timestamp);
  EXPECT_EQ(cv::norm(a.bgr, c.bgr, cv::NORM_INF), 0.0);
  // A different seed gives different textures.
  options.seed = 8;
  const RenderedFrame d = SyntheticScene(options, syntheticCamera()).render(pose.T_w_c, pose.timestamp);
  EXPECT_GT(cv::norm(a.bgr, d.bgr, cv::NORM_L1) / a.bgr.total(), 10.0);
}

TEST(SyntheticScene, DepthNoiseGrowsWithSquaredDepth) {
  SceneOptions noisy;
  noisy.depth_noise_sigma = 0.01;
  const auto pose = sweepPath(1, 30.0)[0];
  const cv::Mat clean = SyntheticScene(SceneOptions{}, syntheticCamera()).render(pose.T_w_c, pose.timestamp).depth;
  const SyntheticScene scene(noisy, syntheticCamera());
  const cv::Mat depth = scene.render(pose.T_w_c, pose.timestamp).depth;
  double sum = 0, sum_sq = 0;
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const double z = clean.at<float>(v, u);
      const double normalised = (depth.at<float>(v, u) - z) / (z * z);
      sum += normalised;
      sum_sq += normalised * normalised;
    }
  }
  const double n = static_cast<double>(depth.total());
  EXPECT_NEAR(sum / n, 0.0, 2e-4);
  EXPECT_NEAR(std::sqrt(sum_sq / n), 0.01, 5e-4);
  // Noise changes from frame to frame.
  const cv::Mat next = scene.render(pose.T_w_c, pose.timestamp + 1.0 / 30).depth;
  EXPECT_GT(cv::norm(depth, next, cv::NORM_INF), 0.0);
}

TEST(SyntheticScene, ImagesHaveManyWellSpreadCorners) {
  const SyntheticScene scene(sceneWithMover(), syntheticCamera());
  const Trajectory path = loopPath(120, 30.0, 1);
  auto orb = cv::ORB::create(2000);
  for (int i : {0, 40, 80}) {
    const RenderedFrame frame = scene.render(path[i].T_w_c, path[i].timestamp);
    cv::Mat grey;
    cv::cvtColor(frame.bgr, grey, cv::COLOR_BGR2GRAY);
    std::vector<cv::KeyPoint> fast;
    cv::FAST(grey, fast, 20, true);
    EXPECT_GT(fast.size(), 1000u) << "frame " << i;
    // Spread: nearly every cell of an 8 x 6 grid has corners.
    std::vector<int> cells(48, 0);
    for (const auto& k : fast) ++cells[int(k.pt.y / 80) * 8 + int(k.pt.x / 80)];
    int empty = 0;
    for (int c : cells) empty += c < 5;
    EXPECT_LE(empty, 2) << "frame " << i;
    std::vector<cv::KeyPoint> keypoints;
    orb->detect(grey, keypoints);
    EXPECT_GE(keypoints.size(), 1000u) << "frame " << i;
  }
}

// Textures must not repeat: ORB matches between nearby frames agree with the true geometry.
TEST(SyntheticScene, OrbMatchesAgreeWithGroundTruth) {
  const CameraOptions camera_options = syntheticCamera();
  const PinholeCamera camera(camera_options);
  const SyntheticScene scene(SceneOptions{}, camera_options);
  const Trajectory path = sweepPath(40, 30.0);
  const auto& a = path[0];
  const auto& b = path[6];  // 0.2 s apart: a tracking-sized motion
  const RenderedFrame fa = scene.render(a.T_w_c, a.timestamp), fb = scene.render(b.T_w_c, b.timestamp);
  auto orb = cv::ORB::create(1500);
  std::vector<cv::KeyPoint> ka, kb;
  cv::Mat da, db;
  orb->detectAndCompute(fa.bgr, cv::noArray(), ka, da);
  orb->detectAndCompute(fb.bgr, cv::noArray(), kb, db);
  std::vector<cv::DMatch> matches;
  cv::BFMatcher(cv::NORM_HAMMING, true).match(da, db, matches);
  ASSERT_GT(matches.size(), 500u);
  const SE3 T_b_a = b.T_w_c.inverse() * a.T_w_c;
  int good = 0;
  for (const auto& m : matches) {
    const cv::Point2f pa = ka[m.queryIdx].pt;
    const float z = fa.depth.at<float>(cvRound(pa.y), cvRound(pa.x));
    const Vec3 p_b = T_b_a * camera.backProject(Vec2(pa.x, pa.y), z);
    const Vec2 expected = camera.project(p_b);
    good += (expected - Vec2(kb[m.trainIdx].pt.x, kb[m.trainIdx].pt.y)).norm() < 4.0;
  }
  EXPECT_GT(double(good) / matches.size(), 0.85) << good << " of " << matches.size();
}

TEST(SyntheticScene, RendersThroughADistortedCamera) {
  CameraOptions camera = syntheticCamera();
  camera.distortion = {0.05, -0.02, 0.0, 0.0, 0.0};
  const SyntheticScene scene(SceneOptions{}, camera);
  const auto pose = sweepPath(1, 30.0)[0];
  const RenderedFrame frame = scene.render(pose.T_w_c, pose.timestamp);
  const PinholeCamera pinhole(camera);
  // A raw pixel's depth belongs to the undistorted ray through it.
  for (const cv::Point2f raw : {cv::Point2f(5, 5), cv::Point2f(600, 400), cv::Point2f(320, 240)}) {
    const cv::Point2f ideal = pinhole.undistort({raw})[0];
    const Vec3 p = pose.T_w_c * pinhole.backProject(Vec2(ideal.x, ideal.y), frame.depth.at<float>(int(raw.y), int(raw.x)));
    EXPECT_LT(scene.distanceToStaticSurface(p), 1e-3);
  }
}

TEST(SyntheticScene, RejectsBadOptionsAndPoses) {
  SceneOptions small;
  small.room_size = Vec3(1.0, 4.0, 3.0);
  EXPECT_THROW(SyntheticScene(small, syntheticCamera()), ConfigError);
  SceneOptions outside = sceneWithMover();
  outside.moving_start = Vec3(5.0, 0.0, 0.0);
  EXPECT_THROW(SyntheticScene(outside, syntheticCamera()), ConfigError);
  SceneOptions noisy;
  noisy.depth_noise_sigma = -1;
  EXPECT_THROW(SyntheticScene(noisy, syntheticCamera()), ConfigError);
  const SyntheticScene scene(SceneOptions{}, syntheticCamera());
  EXPECT_THROW(scene.render(SE3(Quat::Identity(), Vec3(10, 0, 1)), 1000.0), InputError);
}

TEST(SyntheticScene, StaticDistanceIsZeroOnWallsAndPositiveInside) {
  SceneOptions empty_room;
  empty_room.static_boxes = 0;
  const SyntheticScene scene(empty_room, syntheticCamera());
  EXPECT_NEAR(scene.distanceToStaticSurface(Vec3(0, 0, 0)), 0.0, 1e-12);  // floor
  EXPECT_NEAR(scene.distanceToStaticSurface(Vec3(0, 0, 1.5)), 1.5, 1e-12);  // room middle: floor/ceiling 1.5 m
  EXPECT_NEAR(scene.distanceToStaticSurface(Vec3(0, 0, 3.2)), 0.2, 1e-12);  // above the ceiling
}

}  // namespace
}  // namespace desslam::sim
