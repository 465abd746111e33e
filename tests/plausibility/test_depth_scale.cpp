// The depth-scale plausibility check (plausibility/depth_scale.hpp): the ratio it measures
// between the camera's motion in depth-image units and in metres (ground truth) on the synthetic
// room and on the fr1_xyz clip, for depth factors off by 0.2x to 5x; the right factor passes
// without a finding, 2x or more off is an error naming camera.depth_factor with the right factor.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "io/config.hpp"
#include "io/tum_dataset.hpp"
#include "plausibility/depth_scale.hpp"
#include "plausibility/sequence_check.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"
#include "support/shared_data.hpp"

namespace desslam {
namespace {

using plausibility::CheckFrame;
using plausibility::CheckResult;

// Factor multipliers: the config's depth_factor is the right one times this, so depth readings
// come out 1/multiplier times too large (the ratio the check should measure).
const std::vector<double> kMultipliers{0.2, 0.5, 1.0, 2.0, 5.0};

// The frames the check picks from the synthetic sweep's first seconds, rendered.
// `slow_down` stretches the sweep in time (4: ~8 cm/s, the pace of Bonn crowd's start).
std::vector<CheckFrame> syntheticFrames(const PlausibilityOptions& options, double slow_down = 1) {
  const CameraOptions camera = sim::syntheticCamera();
  const sim::SyntheticScene scene(sim::SceneOptions{}, camera);
  Trajectory path = sim::sweepPath(static_cast<int>(options.max_window_s * camera.fps), camera.fps * slow_down);
  for (size_t i = 0; i < path.size(); ++i) path[i].timestamp = static_cast<double>(i) / camera.fps;
  std::vector<Timestamp> stamps;
  std::vector<std::optional<SE3>> reference;
  for (const StampedPose& p : path) {
    stamps.push_back(p.timestamp);
    reference.push_back(p.T_w_c);
  }
  std::vector<CheckFrame> frames;
  for (size_t i : plausibility::selectFrames(stamps, reference, options)) {
    const sim::RenderedFrame rendered = scene.render(path[i].T_w_c, path[i].timestamp);
    CheckFrame f;
    f.timestamp = path[i].timestamp;
    cv::cvtColor(rendered.bgr, f.gray, cv::COLOR_BGR2GRAY);
    f.depth = rendered.depth;
    f.T_w_c_rgb = f.T_w_c_depth = path[i].T_w_c;
    frames.push_back(f);
  }
  return frames;
}

// The frames with depth multiplied by `scale`, as a wrong factor or rescaled PNGs would give.
std::vector<CheckFrame> scaled(std::vector<CheckFrame> frames, double scale) {
  for (CheckFrame& f : frames) {
    cv::Mat depth;  // a new buffer: the copies share their pixels with the caller's frames
    f.depth.convertTo(depth, CV_32F, scale);
    f.depth = depth;
  }
  return frames;
}

void expectVerdict(const CheckResult& result, double multiplier, double right_factor) {
  const double expected_ratio = 1.0 / multiplier;
  ASSERT_TRUE(result.scale.judged) << result.scale.not_judged;
  EXPECT_NEAR(result.scale.ratio, expected_ratio, 0.1 * expected_ratio);
  if (multiplier == 1.0) {
    EXPECT_TRUE(result.findings.empty()) << result.findings.front().message;
    return;
  }
  ASSERT_TRUE(result.hasError()) << "factor x" << multiplier << " passed, ratio " << result.scale.ratio;
  const std::string message = result.firstError();
  EXPECT_NE(message.find("camera.depth_factor"), std::string::npos) << message;
  EXPECT_NE(message.find("likely factor is " + std::to_string(static_cast<int>(right_factor))), std::string::npos)
      << message;
  EXPECT_NE(message.find("--force"), std::string::npos) << message;
}

TEST(DepthScale, SyntheticSceneMeasuresTheFactorsError) {
  const PlausibilityOptions options;
  const std::vector<CheckFrame> frames = syntheticFrames(options);
  ASSERT_GE(frames.size(), static_cast<size_t>(options.min_pairs + 1));
  CameraOptions camera = sim::syntheticCamera();
  for (double m : kMultipliers) {
    SCOPED_TRACE("depth_factor x" + std::to_string(m));
    camera.depth_factor = 5000 * m;
    const CheckResult result = plausibility::checkDepthScale(scaled(frames, 1.0 / m), camera, options);
    std::printf("synthetic, depth_factor x%.1f: ratio %.3f (spread %.1f %%, %zu pairs)%s\n", m, result.scale.ratio,
                100 * result.scale.spread, result.scale.pairs.size(), result.hasError() ? " -> error" : "");
    expectVerdict(result, m, 5000);
  }
}

TEST(DepthScale, DepthPngsDividedByTenAreCaught) {
  const PlausibilityOptions options;
  const CheckResult result =
      plausibility::checkDepthScale(scaled(syntheticFrames(options), 0.1), sim::syntheticCamera(), options);
  ASSERT_TRUE(result.scale.judged) << result.scale.not_judged;
  EXPECT_NEAR(result.scale.ratio, 0.1, 0.01);
  ASSERT_TRUE(result.hasError());
  EXPECT_NE(result.firstError().find("likely factor is 500 "), std::string::npos) << result.firstError();
}

TEST(DepthScale, WithoutGroundTruthOnlyTheRangeIsJudged) {
  const PlausibilityOptions options;
  std::vector<CheckFrame> frames = syntheticFrames(options);
  for (CheckFrame& f : frames) f.T_w_c_rgb = f.T_w_c_depth = std::nullopt;
  const CameraOptions camera = sim::syntheticCamera();
  const CheckResult right = plausibility::checkDepthScale(frames, camera, options);
  EXPECT_FALSE(right.scale.judged);
  EXPECT_NE(right.scale.not_judged.find("no ground truth"), std::string::npos) << right.scale.not_judged;
  EXPECT_TRUE(right.findings.empty());
  // Depth 50x too large: a median of ~100 m is beyond any indoor camera.
  const CheckResult far = plausibility::checkDepthScale(scaled(frames, 50), camera, options);
  ASSERT_TRUE(far.hasError());
  EXPECT_NE(far.firstError().find("median depth"), std::string::npos) << far.firstError();
}

TEST(DepthScale, TooLittleMotionIsNotJudged) {
  PlausibilityOptions options;
  std::vector<CheckFrame> frames = syntheticFrames(options);
  for (CheckFrame& f : frames) f.T_w_c_rgb = f.T_w_c_depth = frames[0].T_w_c_rgb;  // "the camera stood still"
  const CheckResult result = plausibility::checkDepthScale(frames, sim::syntheticCamera(), options);
  EXPECT_FALSE(result.scale.judged);
  EXPECT_FALSE(result.hasError());
}

// Every pair shares the first frame, so an error in its reference pose biases all ratios alike:
// a motion-capture body beside the optical centre (Bonn's ground truth is the marker's pose),
// clock offsets, interpolation give millimetres to a centimetre. Over 3-8 cm baselines that
// read as a 1.23x depth error on Bonn crowd (0.96x over 11-20 cm). Here the first reference is
// 1 cm off towards the path of a camera moving 8 cm/s: the right factor must pass, a factor 2
// off must still be an error.
TEST(DepthScale, AFewMillimetresOfReferenceErrorPassTheRightFactor) {
  const PlausibilityOptions options;
  std::vector<CheckFrame> frames = syntheticFrames(options, 4.0);
  ASSERT_GE(frames.size(), 2u);
  const Vec3 towards_path =
      (frames[1].T_w_c_rgb->translation() - frames[0].T_w_c_rgb->translation()).normalized();
  const SE3 first_reference(frames[0].T_w_c_rgb->quaternion(),
                            frames[0].T_w_c_rgb->translation() + 0.010 * towards_path);
  frames[0].T_w_c_rgb = frames[0].T_w_c_depth = first_reference;
  const CheckResult result = plausibility::checkDepthScale(frames, sim::syntheticCamera(), options);
  std::printf("synthetic, first reference 10 mm off: ratio %.3f (spread %.1f %%, %zu pairs, baselines %.3f-%.3f m)\n",
              result.scale.ratio, 100 * result.scale.spread, result.scale.pairs.size(),
              result.scale.pairs.empty() ? 0.0 : result.scale.pairs.front().reference_m,
              result.scale.pairs.empty() ? 0.0 : result.scale.pairs.back().reference_m);
  ASSERT_TRUE(result.scale.judged) << result.scale.not_judged;
  EXPECT_TRUE(result.findings.empty()) << result.findings.front().message;
  CameraOptions camera = sim::syntheticCamera();
  camera.depth_factor *= 2;
  EXPECT_TRUE(plausibility::checkDepthScale(scaled(frames, 0.5), camera, options).hasError());
}

TEST(DepthScale, SuggestedFactorsAreRoundedToCommonOnes) {
  EXPECT_DOUBLE_EQ(plausibility::suggestedDepthFactor(1000, 5.02), 5000);
  EXPECT_DOUBLE_EQ(plausibility::suggestedDepthFactor(25000, 0.197), 5000);
  EXPECT_DOUBLE_EQ(plausibility::suggestedDepthFactor(5000, 0.2), 1000);
  EXPECT_DOUBLE_EQ(plausibility::suggestedDepthFactor(5000, 0.1), 500);
  EXPECT_DOUBLE_EQ(plausibility::suggestedDepthFactor(5000, 0.3), 1500);
}

TEST(DepthScale, InterpolatesGroundTruth) {
  Trajectory t{{1.0, SE3(Quat::Identity(), Vec3(0, 0, 0))}, {1.1, SE3(Quat::Identity(), Vec3(1, 0, 0))}};
  const std::optional<SE3> mid = plausibility::interpolatePose(t, 1.025);
  ASSERT_TRUE(mid);
  EXPECT_NEAR(mid->translation().x(), 0.25, 1e-9);
  EXPECT_FALSE(plausibility::interpolatePose(t, 0.9));
  EXPECT_FALSE(plausibility::interpolatePose(t, 1.2));
  EXPECT_FALSE(plausibility::interpolatePose(t, 1.05, 0.05));  // gap 0.1 s > 0.05 s
}

// fr1_xyz (../shared clip) read with the fr1 preset and the factor off by 0.2x..5x.
TEST(DepthScale, Fr1XyzClipMeasuresTheFactorsError) {
  const auto clip = test::clipDir("fr1_xyz_0000_0099");
  DESSLAM_REQUIRE_SHARED(clip);
  const SystemOptions preset = io::loadConfig(test::sourceDir() / "config" / "tum_fr1.yaml");
  const io::TumSequence sequence = io::TumSequence::open(clip);
  ASSERT_TRUE(sequence.groundTruth().has_value());
  for (double m : kMultipliers) {
    SCOPED_TRACE("depth_factor x" + std::to_string(m));
    CameraOptions camera = preset.camera;
    camera.depth_factor = preset.camera.depth_factor * m;
    const CheckResult result = plausibility::checkSequence(sequence, camera, preset.plausibility);
    std::printf("fr1_xyz, depth_factor x%.1f: ratio %.3f (spread %.1f %%, %zu pairs), median depth %.2f m%s\n", m,
                result.scale.ratio, 100 * result.scale.spread, result.scale.pairs.size(), result.depth.median_m,
                result.hasError() ? " -> error" : "");
    expectVerdict(result, m, 5000);
  }
}

TEST(DepthScale, WalkersFillingTheViewRaiseNoFalseAlarm) {
  // Bonn crowd frames 300-399: people walk across the view of a moving camera. Its frame pairs'
  // PnP and essential-matrix motions disagree by 26-54 degrees (two motions in the matches) and
  // read 0.74x with the right factor; those pairs are left out, and the right factor gets no
  // finding. Without the direction test (180 degrees allowed) the same frames give the warning.
  const auto clip = test::clipDir("bonn_crowd_0300_0399");
  DESSLAM_REQUIRE_SHARED(clip);
  const SystemOptions preset = io::loadConfig(test::sourceDir() / "config" / "bonn.yaml");
  const io::TumSequence sequence = io::TumSequence::open(clip);
  ASSERT_TRUE(sequence.groundTruth().has_value());
  const CheckResult result = plausibility::checkSequence(sequence, preset.camera, preset.plausibility);
  EXPECT_TRUE(result.findings.empty()) << result.findings.front().message;
  EXPECT_GT(result.scale.pairs_disagreeing, 0);
  for (const plausibility::PairMeasurement& p : result.scale.pairs)
    EXPECT_LE(p.direction_angle_deg, preset.plausibility.max_direction_disagreement_deg);

  PlausibilityOptions unfiltered = preset.plausibility;
  unfiltered.max_direction_disagreement_deg = 180;
  const CheckResult before = plausibility::checkSequence(sequence, preset.camera, unfiltered);
  std::printf("bonn crowd clip: %zu pairs counted (%d left out), %s; unfiltered ratio %.3f over %zu pairs\n",
              result.scale.pairs.size(), result.scale.pairs_disagreeing,
              result.scale.judged ? "judged" : result.scale.not_judged.c_str(), before.scale.ratio,
              before.scale.pairs.size());
  EXPECT_FALSE(before.findings.empty()) << "the clip no longer shows the false alarm this test is about";
}

}  // namespace
}  // namespace desslam
