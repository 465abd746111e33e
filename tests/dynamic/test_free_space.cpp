// The free-space test for features outside the mask, on constructed geometry: a reference frame
// that saw a wall at 2 m, features placed in front of it, on it and behind it, residuals built to
// sit just below / above the threshold, the nearest-reading window, the relative pose.
#include <gtest/gtest.h>

#include "core/error.hpp"
#include "dynamic/constructed_features.hpp"
#include "dynamic/depth_checks.hpp"

namespace desslam::dynamic {
namespace {

using test::around;
using test::depthImage;
using test::makeFeatures;

// Whole pixels: the projected pixel rounds unambiguously (319.5 would sit on a rounding edge).
const cv::Point2f kPixel(300.0f, 200.0f);
constexpr float kWall = 2.0f;

struct FreeSpaceScenario {
  PinholeCamera camera{test::testCameraOptions()};
  cv::Mat reference_depth = depthImage(kWall);
  std::shared_ptr<const map::FeatureSet> current;
  SE3 T_ref_k;

  std::vector<uint8_t> run(const DynamicOptions& options = {}, const std::vector<uint8_t>* tested = nullptr) const {
    FreeSpaceInput in;
    in.current = current.get();
    in.reference_depth = &reference_depth;
    in.T_ref_k = T_ref_k;
    in.test = tested;
    return freeSpaceViolations(in, camera, options);
  }
};

// One feature at kPixel whose own depth (frame k) is z.
FreeSpaceScenario featureAtDepth(float z) {
  FreeSpaceScenario s;
  s.current = makeFeatures({{kPixel, 1}}, s.camera, depthImage(z));
  return s;
}

DynamicOptions threshold12() {
  DynamicOptions options;
  options.stage1_threshold = 0.12;
  return options;
}

TEST(FreeSpace, FeatureOnTheWallIsConsistent) {
  const std::vector<uint8_t> r = featureAtDepth(kWall).run(threshold12());
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0], 0);
}

TEST(FreeSpace, FeatureInFrontOfWhatTheReferenceSawIsAViolation) {
  // The reference saw the wall at 2 m through the place where the point now is (1 m).
  const std::vector<uint8_t> r = featureAtDepth(1.0f).run(threshold12());
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0], 1);
}

TEST(FreeSpace, FeatureBehindWhatTheReferenceSawIsNoEvidence) {
  // The reference saw something nearer (the wall hid the point): occlusion, not motion.
  EXPECT_EQ(featureAtDepth(3.0f).run(threshold12())[0], 0);
}

TEST(FreeSpace, ThresholdIsExactAndComesFromTheOptions) {
  // Residual |1 - d_ref / z_near| with z_near = 2 m: d_ref = 2 (1 - r).
  EXPECT_EQ(featureAtDepth(kWall * (1.0f - 0.119f)).run(threshold12())[0], 0);  // 11.9 %: kept
  EXPECT_EQ(featureAtDepth(kWall * (1.0f - 0.121f)).run(threshold12())[0], 1);  // 12.1 %: dynamic
  DynamicOptions loose;
  loose.stage1_threshold = 0.2;
  EXPECT_EQ(featureAtDepth(kWall * (1.0f - 0.121f)).run(loose)[0], 0);
}

TEST(FreeSpace, NearestReadingInTheWindowDecides) {
  // Far background (4 m) everywhere except one pixel at the feature's own depth, 2 px right and
  // 2 px down of where it projects: the window is 5x5, so that reading counts and the point may
  // be static (a depth edge a pixel or two of pose error away).
  FreeSpaceScenario s = featureAtDepth(kWall);
  const int x = static_cast<int>(kPixel.x), y = static_cast<int>(kPixel.y);
  s.reference_depth = depthImage(4.0f, {{cv::Rect(x + 2, y + 2, 1, 1), kWall}});
  EXPECT_EQ(s.run(threshold12())[0], 0);
  // The same reading 3 px away is outside the window: the reference saw 4 m through the point.
  s.reference_depth = depthImage(4.0f, {{cv::Rect(x + 3, y, 1, 1), kWall}});
  EXPECT_EQ(s.run(threshold12())[0], 1);
  // Invalid readings (0) are skipped, not taken as the nearest: no reading in the 3x3 centre,
  // 4 m on the window's rim, so the reference still saw through the point.
  s.reference_depth = depthImage(4.0f, {{around(kPixel, 1), 0.0f}});
  EXPECT_EQ(s.run(threshold12())[0], 1);
  // No valid reading at all around the projection: no evidence.
  s.reference_depth = depthImage(4.0f, {{around(kPixel, 2), 0.0f}});
  EXPECT_EQ(s.run(threshold12())[0], 0);
}

TEST(FreeSpace, UntestedFeaturesAndFeaturesWithoutDepthGetZero) {
  FreeSpaceScenario s;
  // Three features at 1 m in front of the wall; the second has no depth in frame k.
  const cv::Point2f a(150, 120), b(320, 240), c(480, 360);
  s.current = makeFeatures({{a, 1}, {b, 2}, {c, 3}}, s.camera, depthImage(1.0f, {{around(b, 3), 0.0f}}));
  ASSERT_FALSE(s.current->hasDepth(1));
  const std::vector<uint8_t> all = s.run(threshold12());
  EXPECT_EQ(all, (std::vector<uint8_t>{1, 0, 1}));
  const std::vector<uint8_t> tested = {1, 1, 0};
  EXPECT_EQ(s.run(threshold12(), &tested), (std::vector<uint8_t>{1, 0, 0}));
}

TEST(FreeSpace, RelativePoseIsApplied) {
  // Frame k is 0.1 m to the right of the reference (p_ref = p_k + (0.1, 0, 0)), both facing a
  // wall at 2 m. A point on the wall at kPixel in frame k was at kPixel + fx * 0.1 / 2 = +26.25 px
  // in the reference. The reference saw the wall only around there, far background elsewhere:
  // with the true pose the point is consistent, with no pose or the inverse one it is not.
  FreeSpaceScenario s = featureAtDepth(kWall);
  const cv::Point2f in_reference = kPixel + cv::Point2f(26.25f, 0.0f);
  s.reference_depth = depthImage(4.0f, {{around(in_reference, 4), kWall}});
  const SE3 truth(Quat::Identity(), Vec3(0.1, 0, 0));
  s.T_ref_k = truth;
  EXPECT_EQ(s.run(threshold12())[0], 0);
  s.T_ref_k = SE3();
  EXPECT_EQ(s.run(threshold12())[0], 1);
  s.T_ref_k = truth.inverse();
  EXPECT_EQ(s.run(threshold12())[0], 1);

  // A point that moved: 1 m in front of the wall at kPixel in frame k; where the reference would
  // have seen it, it saw the wall through it.
  FreeSpaceScenario moved = featureAtDepth(1.0f);
  moved.T_ref_k = truth;
  EXPECT_EQ(moved.run(threshold12())[0], 1);
}

TEST(FreeSpace, PointsOutsideTheReferenceViewGetZero) {
  // Shifted 2 m sideways, the point leaves the reference image; 3 m back, it is behind the camera.
  FreeSpaceScenario s = featureAtDepth(1.0f);
  s.T_ref_k = SE3(Quat::Identity(), Vec3(2.0, 0, 0));
  EXPECT_EQ(s.run(threshold12())[0], 0);
  s.T_ref_k = SE3(Quat::Identity(), Vec3(0, 0, -3.0));
  EXPECT_EQ(s.run(threshold12())[0], 0);
}

TEST(FreeSpace, RejectsMissingOrMistypedInputs) {
  const FreeSpaceScenario s = featureAtDepth(kWall);
  FreeSpaceInput in;
  in.current = s.current.get();
  in.reference_depth = nullptr;
  EXPECT_THROW(freeSpaceViolations(in, s.camera, {}), InputError);
  const cv::Mat empty;
  in.reference_depth = &empty;
  EXPECT_THROW(freeSpaceViolations(in, s.camera, {}), InputError);
  const cv::Mat millimetres(480, 640, CV_16UC1, cv::Scalar(2000));
  in.reference_depth = &millimetres;
  EXPECT_THROW(freeSpaceViolations(in, s.camera, {}), InputError);

  in.reference_depth = &s.reference_depth;
  const std::vector<uint8_t> too_long = {1, 1};
  in.test = &too_long;
  EXPECT_THROW(freeSpaceViolations(in, s.camera, {}), InputError);
  const std::vector<uint8_t> too_short;
  in.test = &too_short;
  EXPECT_THROW(freeSpaceViolations(in, s.camera, {}), InputError);

  in.test = nullptr;
  in.current = nullptr;
  EXPECT_THROW(freeSpaceViolations(in, s.camera, {}), InputError);
}

}  // namespace
}  // namespace desslam::dynamic
