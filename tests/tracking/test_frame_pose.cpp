// tracking::optimizeFramePose with visual-odometry points that followed a walker: the previous
// frame's depth at features on a person the masks missed, who has moved since. Built by hand (no
// rendering): static map points seen where the true pose projects them, and VO points whose
// observations are where the walker now is.
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/camera.hpp"
#include "core/camera_options.hpp"
#include "feature/scale_pyramid.hpp"
#include "map/features.hpp"
#include "map/frame.hpp"
#include "map/map.hpp"
#include "tracking/frame_pose.hpp"

namespace desslam::tracking {
namespace {

constexpr double kBf = 40.0;  // TUM-like virtual baseline x fx

PinholeCamera testCamera() {
  CameraOptions o;
  o.fx = o.fy = 525.0;
  o.cx = 319.5;
  o.cy = 239.5;
  return PinholeCamera(o);
}

struct Scene {
  map::Map map;
  map::Frame frame;
  SE3 T_c_w_true;
  int vo_matches = 0;
};

// `map_points` static points and `walker_points` VO points on a walker 1.5 m away who moved
// `walker_step_m` sideways (x) since the previous frame; the camera is at the origin.
void buildScene(Scene& s, int map_points, int walker_points, double walker_step_m, unsigned seed) {
  const PinholeCamera camera = testCamera();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto features = std::make_shared<map::FeatureSet>();
  features->pyramid = std::make_shared<feature::ScalePyramid>(feature::makeScalePyramid(8, 1.2));
  std::vector<Vec3> points_w;
  std::vector<bool> is_vo;
  const auto add = [&](const Vec3& seen_at_c, const Vec3& point_w, bool vo) {
    const Vec2 uv = camera.project(seen_at_c);
    cv::KeyPoint kp(static_cast<float>(uv.x()), static_cast<float>(uv.y()), 31.0f);
    kp.octave = 0;
    features->keypoints.push_back(kp);
    features->uv.push_back(uv);
    features->depth.push_back(static_cast<float>(seen_at_c.z()));
    points_w.push_back(point_w);
    is_vo.push_back(vo);
  };
  for (int i = 0; i < map_points; ++i) {
    const double z = 1.5 + 2.0 * u(rng);
    const Vec3 p(z * (u(rng) - 0.5) * 1.1, z * (u(rng) - 0.5) * 0.8, z);
    add(p, p, false);
  }
  // The walker: a 0.5 x 1.2 m body around (0.3, 0, 1.5).
  for (int i = 0; i < walker_points; ++i) {
    const Vec3 before(0.05 + 0.5 * u(rng), -0.6 + 1.2 * u(rng), 1.5 + 0.1 * u(rng));
    add(before + Vec3(walker_step_m, 0, 0), before, true);
  }
  features->descriptors = cv::Mat::zeros(static_cast<int>(features->keypoints.size()), 32, CV_8U);
  s.frame = map::Frame(1, 1.0, "test", features);
  for (size_t i = 0; i < points_w.size(); ++i) {
    if (is_vo[i]) {
      s.frame.matches[i].has_vo_point = true;
      s.frame.matches[i].vo_point = points_w[i];
      ++s.vo_matches;
    } else {
      s.frame.matches[i].point = s.map.createPoint(points_w[i], nullptr);
    }
  }
  s.T_c_w_true = SE3::identity();
}

int voMatchesLeft(const map::Frame& frame) {
  int n = 0;
  for (const auto& m : frame.matches) n += m.has_vo_point && m.point == nullptr;
  return n;
}

double centreError(const SE3& a, const SE3& b) { return (a.inverse().translation() - b.inverse().translation()).norm(); }

// The motion model starts from the pose the walker's points suggest (the camera "moved" against
// his step): the prediction of a frame that has followed him so far.
SE3 walkerPrediction(double walker_step_m) { return SE3(Mat3::Identity(), Vec3(-walker_step_m, 0, 0)); }

TEST(FramePoseVoCheck, WalkerVoPointsDoNotMoveAStillCamera) {
  for (unsigned seed : {1u, 2u, 3u}) {
    for (double step : {0.02, 0.04}) {
      Scene s;
      buildScene(s, 60, 150, step, seed);
      s.frame.T_c_w = walkerPrediction(step);
      const int inliers = optimizeFramePose(s.frame, s.map, testCamera(), kBf, 20);
      EXPECT_EQ(inliers, 60) << "seed " << seed << ", step " << step;
      EXPECT_LT(centreError(s.frame.T_c_w, s.T_c_w_true), 0.002) << "seed " << seed << ", step " << step;
      EXPECT_EQ(voMatchesLeft(s.frame), 0) << "the walker's VO points should be dropped";
    }
  }
}

TEST(FramePoseVoCheck, WithoutTheCheckTheWalkerPullsThePose) {
  // What the check is for: the same frame optimised on all its matches follows the walker.
  Scene s;
  buildScene(s, 60, 150, 0.04, 1);
  s.frame.T_c_w = walkerPrediction(0.04);
  optimizeFramePose(s.frame, s.map, testCamera(), kBf, 0);
  EXPECT_GT(centreError(s.frame.T_c_w, s.T_c_w_true), 0.01);
}

TEST(FramePoseVoCheck, VoPointsThatAgreeWithTheMapAreKept) {
  // A static VO point (walker step 0) supports the pose: the check keeps it.
  Scene s;
  buildScene(s, 60, 150, 0.0, 4);
  s.frame.T_c_w = SE3(Mat3::Identity(), Vec3(0.01, 0, 0));
  optimizeFramePose(s.frame, s.map, testCamera(), kBf, 20);
  EXPECT_EQ(voMatchesLeft(s.frame), s.vo_matches);
  EXPECT_LT(centreError(s.frame.T_c_w, s.T_c_w_true), 0.002);
}

TEST(FramePoseVoCheck, TooFewMapPointsLeaveTheVoPointsAlone) {
  // A thin map (fewer map points than the check needs) cannot judge: every match is used, as before.
  Scene s;
  buildScene(s, 12, 150, 0.04, 5);
  s.frame.T_c_w = walkerPrediction(0.04);
  Scene reference;
  buildScene(reference, 12, 150, 0.04, 5);
  reference.frame.T_c_w = walkerPrediction(0.04);
  optimizeFramePose(s.frame, s.map, testCamera(), kBf, 20);
  optimizeFramePose(reference.frame, reference.map, testCamera(), kBf, 0);
  EXPECT_LT(centreError(s.frame.T_c_w, reference.frame.T_c_w), 1e-9);
  EXPECT_EQ(voMatchesLeft(s.frame), voMatchesLeft(reference.frame));
}

}  // namespace
}  // namespace desslam::tracking
