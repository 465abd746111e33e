// Keyframes made while the mask was carried forward get their own frame's mask before local
// mapping uses them (semantic.keyframe_exact_mask): a person-sized box walks through the
// synthetic room, its true masks come 10 frames late (emulated latency, deterministic), and the
// features the late mask missed on the box leave the keyframes.
// Also dynamic.mask_hold_previous: on a frame whose segmentation misses the box, the previous
// frame's mask (carried along the flow) still covers it.
#include <cstdio>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include <gtest/gtest.h>

#include "eval/evaluation.hpp"
#include "io/tum_dataset.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"
#include "support/temp_dir.hpp"
#include "system/slam_system.hpp"
#include "system_support.hpp"

namespace desslam {
namespace {

constexpr int kFrames = 120;

struct MaskRun {
  nlohmann::json statistics;
  double ate_m = 0;
  size_t tracked = 0;
};

MaskRun runWithLateMasks(const std::filesystem::path& dir, bool keyframe_exact_mask, bool deterministic = true,
                         int latency_frames = 10, bool mask_hold_previous = true) {
  const io::TumSequence sequence = io::TumSequence::open(dir);
  SystemOptions options = test::syntheticSystemOptions();
  options.semantic.segmenter = SegmenterKind::kMaskDir;
  options.semantic.mask_dir = (dir / "masks").string();
  options.semantic.keyframe_exact_mask = keyframe_exact_mask;
  options.dynamic.mask_hold_previous = mask_hold_previous;
  options.dynamic.mode = DynamicMode::kSemantic;  // the masks alone decide: no depth check hides what they miss
  // The carried mask as it is carried, not grown for its age: a grown one covers the box anyway here.
  options.dynamic.carried_mask_growth_px = 0;
  system::RunSettings settings;
  settings.deterministic = deterministic;
  settings.mask_latency_frames = latency_frames;
  settings.mask_period_frames = latency_frames > 0 ? 3 : 1;
  system::SlamSystem slam(options, settings);
  for (size_t i = 0; i < sequence.size(); ++i) {
    const io::RgbdImage image = sequence.load(i, options.camera);
    slam.processFrame(image.timestamp, image.bgr, image.depth, sequence.record(i).rgb_path.filename().string());
  }
  slam.finish();
  MaskRun run;
  run.statistics = slam.statistics();
  const Trajectory camera = slam.cameraTrajectory();
  run.tracked = camera.size();
  run.ate_m = eval::computeAte(*sequence.groundTruth(), camera).translation_m.rmse;
  return run;
}

void writeWalkingBoxSequence(const std::filesystem::path& dir) {
  const CameraOptions camera = sim::syntheticCamera();
  sim::SceneOptions scene_options;
  scene_options.moving_object = true;
  const sim::SyntheticScene scene(scene_options, camera);
  sim::writeSequence(dir, scene, sim::sweepPath(kFrames, camera.fps), camera, /*write_masks=*/true);
}

TEST(SystemKeyframeMasks, LateMaskedKeyframesGetTheirOwnMask) {
  test::TempDir dir;
  writeWalkingBoxSequence(dir.path());

  const MaskRun with = runWithLateMasks(dir.path(), true);
  const MaskRun without = runWithLateMasks(dir.path(), false);
  const nlohmann::json& own = with.statistics["semantic"]["keyframe_own_masks"];
  std::printf("keyframe own masks: %s\nATE with %.2f mm (%zu tracked), without %.2f mm (%zu tracked)\n",
              own.dump().c_str(), 1000 * with.ate_m, with.tracked, 1000 * without.ate_m, without.tracked);

  // Before the map starts, tracking has no pose to be late with: the first frame waits for its own
  // mask (semantic.own_mask_when_lost); then masks come 10-12 frames late.
  const nlohmann::json& per_frame = with.statistics["per_frame"];
  ASSERT_EQ(per_frame.size(), static_cast<size_t>(kFrames));
  EXPECT_TRUE(per_frame[0]["own_mask_waited"].get<bool>());
  EXPECT_EQ(per_frame[0]["mask_age"].get<int>(), 0);
  size_t late_keyframes = 0, tracked_late = 0;
  for (const nlohmann::json& f : per_frame) {
    if (!f["tracked"].get<bool>()) continue;
    late_keyframes += f["keyframe"].get<bool>() && f["mask_age"].get<int>() != 0;
    if (f["mask_age"].get<int>() >= 6) ++tracked_late;
  }
  EXPECT_GE(tracked_late, static_cast<size_t>(0.9 * kFrames)) << "tracked frames used late masks";
  // Every keyframe with a late mask asked for its own and got it.
  ASSERT_GT(late_keyframes, 2u);
  EXPECT_EQ(own["requested"].get<size_t>(), late_keyframes);
  EXPECT_EQ(own["applied"].get<size_t>(), late_keyframes);
  // Offline, every frame is segmented anyway: none needs a segmentation of its own.
  EXPECT_EQ(with.statistics["semantic"]["own_mask_segmentations"].get<size_t>(), 0u);
  // Lost frames (here the first, before the map) asked for their own too.
  EXPECT_EQ(with.statistics["semantic"]["own_mask_requests"].get<size_t>(), late_keyframes + 1);
  // The box moves: the late mask missed part of it, and its own mask finds features there.
  EXPECT_GT(own["features_removed"].get<size_t>(), 0u);
  EXPECT_GT(own["points_removed"].get<size_t>(), 0u);
  // Switched off, nothing is asked for.
  EXPECT_EQ(without.statistics["semantic"]["keyframe_own_masks"]["requested"].get<size_t>(), 0u);

  EXPECT_GE(with.tracked, static_cast<size_t>(0.95 * kFrames));
  // Fewer points on the walking box: the trajectory is no worse (deterministic runs).
  EXPECT_LE(with.ate_m, without.ate_m + 1e-4);
}

// With the mapping thread: local mapping waits for each keyframe's own mask on its own thread
// while tracking goes on (the ThreadSanitizer build runs this too).
TEST(SystemKeyframeMasks, MappingThreadWaitsForTheKeyframesOwnMask) {
  test::TempDir dir;
  writeWalkingBoxSequence(dir.path());
  const MaskRun threaded = runWithLateMasks(dir.path(), true, /*deterministic=*/false);
  const nlohmann::json& own = threaded.statistics["semantic"]["keyframe_own_masks"];
  EXPECT_GT(own["requested"].get<size_t>(), 2u);
  EXPECT_EQ(own["applied"].get<size_t>(), own["requested"].get<size_t>());
  EXPECT_GT(own["features_removed"].get<size_t>(), 0u);
  EXPECT_GE(threaded.tracked, static_cast<size_t>(0.95 * kFrames));
}

// The segmentation drops the box on single frames (as DeepLab drops people now and then): the
// masks of those frames are emptied. Offline, every frame has its own (fresh) mask.
TEST(SystemMaskHold, AFrameWhoseMaskMissesThePersonKeepsThePreviousMask) {
  test::TempDir dir;
  writeWalkingBoxSequence(dir.path());
  const io::TumSequence sequence = io::TumSequence::open(dir.path());
  const auto mask_file = [&](size_t i) { return dir.path() / "masks" / sequence.record(i).rgb_path.filename(); };
  const auto box_share = [&](size_t i) {
    const cv::Mat mask = cv::imread(mask_file(i).string(), cv::IMREAD_GRAYSCALE);
    return static_cast<double>(cv::countNonZero(mask)) / static_cast<double>(mask.total());
  };
  // Dropouts on frames (10 apart) where the box covers a few percent of the view on the frame and
  // the frame before.
  std::vector<size_t> dropped;
  for (size_t i = 20; i + 1 < sequence.size() && dropped.size() < 4; ++i) {
    if ((dropped.empty() || i >= dropped.back() + 10) && box_share(i) > 0.02 && box_share(i - 1) > 0.02) {
      dropped.push_back(i);
    }
  }
  ASSERT_GE(dropped.size(), 2u) << "the box is in view for too few frames";
  for (const size_t i : dropped) {
    const cv::Mat mask = cv::imread(mask_file(i).string(), cv::IMREAD_UNCHANGED);
    ASSERT_TRUE(cv::imwrite(mask_file(i).string(), cv::Mat::zeros(mask.size(), mask.type())));
  }

  const MaskRun held = runWithLateMasks(dir.path(), false, true, /*latency_frames=*/0, /*mask_hold_previous=*/true);
  const MaskRun fresh_only = runWithLateMasks(dir.path(), false, true, 0, false);
  const nlohmann::json& with = held.statistics["per_frame"];
  const nlohmann::json& without = fresh_only.statistics["per_frame"];
  ASSERT_EQ(with.size(), sequence.size());
  ASSERT_EQ(without.size(), sequence.size());
  for (const size_t i : dropped) {
    SCOPED_TRACE("dropped mask on frame " + std::to_string(i));
    const int before = without[i - 1]["in_mask"].get<int>();  // features on the box the frame before
    ASSERT_GT(before, 10);
    EXPECT_EQ(without[i]["in_mask"].get<int>(), 0) << "without the hold nothing is masked";
    EXPECT_GT(with[i]["in_mask"].get<int>(), before / 2) << "the held mask covers the box";
    // The hold does not mask what no segmentation saw: on the frame before (its own mask and the
    // one before it, both with the box) about as much is masked.
    EXPECT_LT(with[i - 1]["in_mask"].get<int>(), 2 * before + 20);
  }
  EXPECT_GE(held.tracked, static_cast<size_t>(0.95 * kFrames));
}

}  // namespace
}  // namespace desslam
