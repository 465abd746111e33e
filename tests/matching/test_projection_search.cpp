// matching::searchByProjection and its scope: which features it may take (the usable ones, or a
// given list) and, for the list, the stage-1 depth test against the point (|1 - z_point / z| <= bound).
#include <memory>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/camera.hpp"
#include "feature/scale_pyramid.hpp"
#include "map/features.hpp"
#include "map/frame.hpp"
#include "map/map_types.hpp"
#include "matching/matcher.hpp"

namespace desslam::matching {
namespace {

CameraOptions cameraOptions() {
  CameraOptions c;
  c.fx = c.fy = 500;
  c.cx = 320;
  c.cy = 240;
  return c;
}

// Four features at well separated pixels, each with its own random descriptor, all at 2 m, but
// feature 3 at depth_3.
struct Scene {
  PinholeCamera camera{cameraOptions()};
  std::vector<Vec2> pixels{{100, 100}, {300, 200}, {500, 300}, {200, 400}};
  cv::Mat descriptors{4, 32, CV_8U};
  map::Frame frame;
  std::vector<std::unique_ptr<map::MapPoint>> points;  // one per feature, where the feature sees it at 2 m

  explicit Scene(float depth_3) {
    cv::RNG rng(7);
    rng.fill(descriptors, cv::RNG::UNIFORM, 0, 256);
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat depth(480, 640, CV_32F, cv::Scalar(2.0f));
    for (size_t i = 0; i < pixels.size(); ++i) keypoints.emplace_back(float(pixels[i].x()), float(pixels[i].y()), 31.f, 0.f, 0.f, 0);
    cv::circle(depth, cv::Point(200, 400), 4, cv::Scalar(depth_3), cv::FILLED);
    auto pyramid = std::make_shared<feature::ScalePyramid>(feature::makeScalePyramid(8, 1.2));
    frame = map::Frame(0, 0.0, "f", map::buildFeatureSet(keypoints, descriptors, camera, depth, pyramid, 0.1, 8.0));
    frame.T_c_w = SE3();
    for (size_t i = 0; i < pixels.size(); ++i) {
      const Vec3 position((pixels[i].x() - 320) / 500 * 2.0, (pixels[i].y() - 240) / 500 * 2.0, 2.0);
      points.push_back(std::make_unique<map::MapPoint>(i + 1, position, nullptr, 0));
    }
  }

  std::vector<ProjectionCandidate> candidates() {
    std::vector<ProjectionCandidate> result;
    for (size_t i = 0; i < points.size(); ++i) {
      ProjectionCandidate c;
      c.p_w = points[i]->position;
      c.point = points[i].get();
      c.descriptor = descriptors.ptr<uint8_t>(static_cast<int>(i));
      c.max_level = 0;
      c.radius = 8;
      result.push_back(c);
    }
    return result;
  }
};

TEST(ProjectionSearch, ByDefaultOnlyUsableFeaturesAreTaken) {
  Scene scene(2.0f);
  scene.frame.status[1] = map::FeatureStatus::kDynamicStage1;
  EXPECT_EQ(searchByProjection(scene.frame, scene.camera, scene.candidates(), MatcherOptions{}), 3);
  EXPECT_EQ(scene.frame.matches[0].point, scene.points[0].get());
  EXPECT_EQ(scene.frame.matches[1].point, nullptr);
  EXPECT_EQ(scene.frame.matches[3].point, scene.points[3].get());
}

TEST(ProjectionSearch, AScopeTakesItsListedFeaturesWhateverTheirStatus) {
  Scene scene(2.0f);
  for (auto& s : scene.frame.status) s = map::FeatureStatus::kDynamicStage1;
  const std::vector<uint8_t> eligible{0, 1, 0, 1};
  ProjectionSearchScope scope;
  scope.eligible = &eligible;
  EXPECT_EQ(searchByProjection(scene.frame, scene.camera, scene.candidates(), MatcherOptions{}, scope), 2);
  EXPECT_EQ(scene.frame.matches[0].point, nullptr);
  EXPECT_EQ(scene.frame.matches[1].point, scene.points[1].get());
  EXPECT_EQ(scene.frame.matches[3].point, scene.points[3].get());
  const std::vector<uint8_t> wrong_size{1, 1};
  scope.eligible = &wrong_size;
  EXPECT_THROW(searchByProjection(scene.frame, scene.camera, scene.candidates(), MatcherOptions{}, scope),
               std::invalid_argument);
}

// Feature 3 sees its point at 2 m from 2.16 m (7 % off: taken) or 2.4 m (17 %: not), against a bound
// of 12 %; without the bound both are taken (the default window allows either disparity).
TEST(ProjectionSearch, TheDepthBoundKeepsAFeatureAtAnotherDepthThanThePoint) {
  const std::vector<uint8_t> eligible{1, 1, 1, 1};
  for (const float depth_3 : {2.16f, 2.4f}) {
    for (const bool bounded : {false, true}) {
      Scene scene(depth_3);
      ASSERT_NEAR(scene.frame.features->depth[3], depth_3, 1e-6);
      ProjectionSearchScope scope;
      scope.eligible = &eligible;
      scope.max_relative_depth_residual = bounded ? 0.12 : 0.0;
      searchByProjection(scene.frame, scene.camera, scene.candidates(), MatcherOptions{}, scope);
      const bool taken = scene.frame.matches[3].point == scene.points[3].get();
      EXPECT_EQ(taken, !bounded || depth_3 < 2.2f) << "depth " << depth_3 << (bounded ? " bounded" : "");
      EXPECT_EQ(scene.frame.matches[0].point, scene.points[0].get());
    }
  }
}

}  // namespace
}  // namespace desslam::matching
