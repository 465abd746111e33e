// Stage 1 on constructed geometry: residuals built to sit just below / above the threshold,
// static and moving features inside the mask, sideways motion, the unmatched policy.
#include <cmath>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "dynamic/depth_checks.hpp"
#include "dynamic/constructed_features.hpp"

namespace desslam::dynamic {
namespace {

using test::around;
using test::depthImage;
using test::makeFeatures;

const cv::Point2f kCentre(319.5f, 239.5f);  // the principal point: back-projects onto the optical axis

struct Scenario {
  PinholeCamera camera{test::testCameraOptions()};
  cv::Mat previous_depth, current_depth;
  std::shared_ptr<const map::FeatureSet> previous, current;
  cv::Mat mask = cv::Mat(480, 640, CV_8UC1, cv::Scalar(255));  // everything is "person"
  SE3 T_k_km1;

  Stage1Result run(const DynamicOptions& options = {}) const {
    Stage1Input in;
    in.current = current.get();
    in.current_depth = &current_depth;
    in.mask = &mask;
    in.previous = previous.get();
    in.T_k_km1 = T_k_km1;
    return runStage1(in, camera, options);
  }
};

TEST(DepthResidual, IsRelativeToTheObservedDepthAndStrict) {
  EXPECT_DOUBLE_EQ(relativeDepthResidual(2.0, 1.76), 0.12);
  EXPECT_NEAR(relativeDepthResidual(2.0, 2.24), 0.12, 1e-12);
  EXPECT_DOUBLE_EQ(relativeDepthResidual(2.0, 2.0), 0.0);
  EXPECT_FALSE(exceeds(0.12, 0.12));
  EXPECT_TRUE(exceeds(0.12 + 1e-12, 0.12));
}

TEST(MedianDepth, IgnoresOneFlyingPixelAndMissingReadings) {
  cv::Mat d(5, 5, CV_32FC1, cv::Scalar(2.0f));
  d.at<float>(2, 2) = 9.0f;  // flying pixel
  d.at<float>(1, 1) = 0.0f;  // no reading
  EXPECT_FLOAT_EQ(medianDepth3x3(d, 2, 2), 2.0f);
  EXPECT_FLOAT_EQ(medianDepth3x3(d, 0, 0), 2.0f);  // corner: only the 2x2 inside counts
  EXPECT_EQ(medianDepth3x3(d, -1, 2), 0.0);
  EXPECT_EQ(medianDepth3x3(cv::Mat(3, 3, CV_32FC1, cv::Scalar(0)), 1, 1), 0.0);
}

// A feature on the optical axis at 2 m in both frames; the camera moves along its axis by tz, so
// the frame k-1 point lands at depth 2 + tz in frame k: residual exactly |tz| / 2.
Scenario axialScenario(double tz) {
  Scenario s;
  s.previous_depth = depthImage(2.0f);
  s.current_depth = depthImage(2.0f);
  s.previous = makeFeatures({{kCentre, 1}}, s.camera, s.previous_depth);
  s.current = makeFeatures({{kCentre, 1}}, s.camera, s.current_depth);
  s.T_k_km1 = SE3(Quat::Identity(), Vec3(0, 0, tz));
  return s;
}

TEST(Stage1, ResidualJustBelowThresholdIsKept) {
  const Stage1Result r = axialScenario(-0.238).run();  // 11.9 %
  ASSERT_EQ(r.outcome.size(), 1u);
  EXPECT_NEAR(r.residual_forward[0], 0.119, 1e-9);
  EXPECT_NEAR(r.residual_sideways[0], 0.119, 1e-9);
  EXPECT_EQ(r.previous_index[0], 0);
  EXPECT_EQ(r.outcome[0], Stage1Outcome::kConsistent);
  EXPECT_EQ(r.dynamic[0], 0);
  EXPECT_EQ(r.consistent_count, 1);
}

TEST(Stage1, ResidualJustAboveThresholdIsRemoved) {
  const Stage1Result r = axialScenario(-0.242).run();  // 12.1 %
  EXPECT_NEAR(r.residual_forward[0], 0.121, 1e-9);
  EXPECT_EQ(r.outcome[0], Stage1Outcome::kDynamic);
  EXPECT_EQ(r.dynamic[0], 1);
  EXPECT_EQ(r.dynamic_count, 1);
  EXPECT_EQ(r.removed_count, 1);
  // Same on the far side: the point ends up 12.1 % deeper than observed.
  const Stage1Result far = axialScenario(0.242).run();
  EXPECT_NEAR(far.residual_forward[0], 0.121, 1e-9);
  EXPECT_EQ(far.dynamic[0], 1);
}

// The matched frame k-1 point re-projects dx pixels beside the feature, at the same depth: a
// static point would land on it, so beyond stage1_max_reprojection_px it moved in the image.
Scenario displacedScenario(float dx) {
  Scenario s;
  s.previous_depth = depthImage(2.0f);
  s.current_depth = depthImage(2.0f);
  s.previous = makeFeatures({{kCentre, 1}}, s.camera, s.previous_depth);
  s.current = makeFeatures({{kCentre + cv::Point2f(dx, 0), 1}}, s.camera, s.current_depth);
  return s;
}

TEST(Stage1, FeatureDisplacedFromItsReprojectionIsDynamicEvenWithConsistentDepth) {
  DynamicOptions options;  // 4 px at level 0
  const Stage1Result near = displacedScenario(3.9f).run(options);
  EXPECT_NEAR(near.residual_forward[0], 0.0, 1e-9);
  EXPECT_EQ(near.outcome[0], Stage1Outcome::kConsistent);
  const Stage1Result far = displacedScenario(4.1f).run(options);
  EXPECT_NEAR(far.residual_forward[0], 0.0, 1e-9);
  EXPECT_EQ(far.previous_index[0], 0);
  EXPECT_EQ(far.outcome[0], Stage1Outcome::kDynamic);
  options.stage1_max_reprojection_px = 5.0;
  EXPECT_EQ(displacedScenario(4.1f).run(options).outcome[0], Stage1Outcome::kConsistent);
}

TEST(Stage1, ThresholdComesFromTheOptions) {
  DynamicOptions loose;
  loose.stage1_threshold = 0.2;
  EXPECT_EQ(axialScenario(-0.242).run(loose).dynamic[0], 0);
}

// The camera slides 0.1 m sideways in front of a wall at 2 m: every feature shifts by
// fx * 0.1 / 2 = 26.25 px and keeps its depth. People standing still in the mask stay.
TEST(Stage1, StaticFeaturesInsideTheMaskStay) {
  Scenario s;
  s.previous_depth = depthImage(2.0f);
  s.current_depth = depthImage(2.0f);
  std::vector<test::PlacedFeature> before, after;
  int id = 0;
  for (float v : {100.5f, 240.0f, 380.25f})
    for (float u : {150.0f, 300.5f, 450.75f}) {
      before.push_back({{u, v}, id});
      after.push_back({{u + 26.25f, v}, id});
      ++id;
    }
  s.previous = makeFeatures(before, s.camera, s.previous_depth);
  s.current = makeFeatures(after, s.camera, s.current_depth);
  s.T_k_km1 = SE3(Quat::Identity(), Vec3(0.1, 0, 0));  // p_k = p_km1 + t
  const Stage1Result r = s.run();
  EXPECT_EQ(r.in_mask_count, 9);
  EXPECT_EQ(r.consistent_count, 9);
  EXPECT_EQ(r.removed_count, 0);
  for (size_t i = 0; i < r.outcome.size(); ++i) {
    EXPECT_EQ(r.previous_index[i], static_cast<int>(i));
    EXPECT_NEAR(r.residual_forward[i], 0.0, 1e-6);
    EXPECT_NEAR(r.residual_sideways[i], 0.0, 1e-6);
  }
}

// A person 2 m away steps 0.4 m towards the static camera; the wall behind stays at 3 m.
TEST(Stage1, FeatureOnObjectMovingTowardsTheCameraIsRemoved) {
  Scenario s;
  const cv::Point2f on_person(300, 200), on_wall(420, 300);
  s.previous_depth = depthImage(3.0f, {{around(on_person, 20), 2.0f}});
  s.current_depth = depthImage(3.0f, {{around(on_person, 20), 1.6f}});
  s.previous = makeFeatures({{on_person, 1}, {on_wall, 2}}, s.camera, s.previous_depth);
  s.current = makeFeatures({{on_person, 1}, {on_wall, 2}}, s.camera, s.current_depth);
  const Stage1Result r = s.run();
  EXPECT_NEAR(r.residual_forward[0], 0.25, 1e-6);
  EXPECT_EQ(r.outcome[0], Stage1Outcome::kDynamic);
  EXPECT_EQ(r.outcome[1], Stage1Outcome::kConsistent);
  EXPECT_EQ(r.dynamic[1], 0);
}

// An object at 1.5 m in front of a 3 m wall moves 10 px to the right, keeping its depth: the
// forward residual sees nothing, the sideways one finds the wall where the object was.
TEST(Stage1, SidewaysMotionIsCaughtByTheSecondResidual) {
  Scenario s;
  const cv::Point2f before(200, 240), after(210, 240);
  s.previous_depth = depthImage(3.0f, {{around(before, 3), 1.5f}});
  s.current_depth = depthImage(3.0f, {{around(after, 3), 1.5f}});
  s.previous = makeFeatures({{before, 1}}, s.camera, s.previous_depth);
  s.current = makeFeatures({{after, 1}}, s.camera, s.current_depth);
  const Stage1Result r = s.run();
  EXPECT_NEAR(r.residual_forward[0], 0.0, 1e-6);
  EXPECT_NEAR(r.residual_sideways[0], 0.5, 1e-6);
  EXPECT_EQ(r.outcome[0], Stage1Outcome::kDynamic);
}

TEST(Stage1, FeaturesOutsideTheDilatedMaskAreNotChecked) {
  Scenario s = axialScenario(-0.3);  // would be dynamic if checked
  s.mask.setTo(0);
  s.mask.at<uint8_t>(240, 325) = 255;  // 5 px right of the feature (at 320, 240 rounded)
  DynamicOptions options;
  options.mask_dilation_px = 4;
  EXPECT_EQ(s.run(options).outcome[0], Stage1Outcome::kNotChecked);
  options.mask_dilation_px = 5;
  EXPECT_EQ(s.run(options).outcome[0], Stage1Outcome::kDynamic);
}

TEST(Stage1, WithoutAMaskEveryFeatureIsChecked) {
  const Scenario s = axialScenario(-0.3);
  Stage1Input in;
  in.current = s.current.get();
  in.current_depth = &s.current_depth;
  in.previous = s.previous.get();
  in.T_k_km1 = s.T_k_km1;
  EXPECT_EQ(runStage1(in, s.camera, {}).outcome[0], Stage1Outcome::kDynamic);
}

// Feature 0 has no counterpart in frame k-1, feature 1 no depth in frame k, feature 2 matches a
// frame k-1 feature without depth.
Scenario uncheckableScenario() {
  Scenario s;
  const cv::Point2f a(100, 100), b(300, 300), c(500, 200);
  s.previous_depth = depthImage(2.0f, {{around(c, 2), 0.0f}});
  s.current_depth = depthImage(2.0f, {{around(b, 2), 0.0f}});
  s.previous = makeFeatures({{a, 10}, {b, 2}, {c, 3}}, s.camera, s.previous_depth);
  s.current = makeFeatures({{a, 1}, {b, 2}, {c, 3}}, s.camera, s.current_depth);
  return s;
}

TEST(Stage1, UncheckableFeaturesAreKeptUnderPolicyKeep) {
  DynamicOptions keep;
  keep.stage1_unmatched_policy = UnmatchedPolicy::kKeep;
  const Stage1Result r = uncheckableScenario().run(keep);
  EXPECT_EQ(r.outcome[0], Stage1Outcome::kUnmatched);
  EXPECT_EQ(r.outcome[1], Stage1Outcome::kNoDepth);
  EXPECT_EQ(r.outcome[2], Stage1Outcome::kNoDepth);
  EXPECT_EQ(r.previous_index[0], -1);
  EXPECT_EQ(r.previous_index[2], 2);
  EXPECT_EQ(r.unmatched_count, 1);
  EXPECT_EQ(r.no_depth_count, 2);
  EXPECT_EQ(r.removed_count, 0);
  EXPECT_TRUE(std::isnan(r.residual[0]));
}

TEST(Stage1, UncheckableFeaturesAreRemovedUnderPolicyDrop) {
  DynamicOptions options;
  options.stage1_unmatched_policy = UnmatchedPolicy::kDrop;
  const Stage1Result r = uncheckableScenario().run(options);
  EXPECT_EQ(r.outcome[0], Stage1Outcome::kUnmatched);  // still reported apart from kDynamic
  EXPECT_EQ(r.dynamic_count, 0);
  EXPECT_EQ(r.removed_count, 3);
  EXPECT_EQ(r.dynamic, (std::vector<uint8_t>{1, 1, 1}));
}

TEST(Stage1, AmbiguousMatchesAreRejected) {
  Scenario s;
  s.previous_depth = depthImage(2.0f);
  s.current_depth = depthImage(1.0f);  // would be dynamic if matched
  // Two identical descriptors in the window: repeated texture, no trustworthy correspondence.
  s.previous = makeFeatures({{{300, 240}, 1}, {{310, 240}, 1}}, s.camera, s.previous_depth);
  s.current = makeFeatures({{{305, 240}, 1}}, s.camera, s.current_depth);
  EXPECT_EQ(s.run().outcome[0], Stage1Outcome::kUnmatched);
}

TEST(Stage1, CallerCorrespondencesReplaceMatching) {
  Scenario s = uncheckableScenario();
  Stage1Input in;
  in.current = s.current.get();
  in.current_depth = &s.current_depth;
  in.mask = &s.mask;
  in.previous = s.previous.get();
  const std::vector<int> matches{0, -1, -1};  // feature 0 paired with the lookalike-free k-1 feature 0
  in.previous_match = &matches;
  const Stage1Result r = runStage1(in, s.camera, {});
  EXPECT_EQ(r.outcome[0], Stage1Outcome::kConsistent);
  EXPECT_EQ(r.outcome[2], Stage1Outcome::kUnmatched);
  const std::vector<int> wrong_size{0};
  in.previous_match = &wrong_size;
  EXPECT_THROW(runStage1(in, s.camera, {}), InputError);
}

TEST(Stage1, RejectsMissingOrMistypedInputs) {
  const Scenario s = axialScenario(0);
  Stage1Input in;
  in.current = s.current.get();
  in.previous = s.previous.get();
  EXPECT_THROW(runStage1(in, s.camera, {}), InputError);  // no depth
  const cv::Mat wrong_type(480, 640, CV_16UC1, cv::Scalar(0));
  in.current_depth = &wrong_type;
  EXPECT_THROW(runStage1(in, s.camera, {}), InputError);
  in.current_depth = &s.current_depth;
  const cv::Mat small_mask(10, 10, CV_8UC1, cv::Scalar(0));
  in.mask = &small_mask;
  EXPECT_THROW(runStage1(in, s.camera, {}), InputError);
}

}  // namespace
}  // namespace desslam::dynamic
