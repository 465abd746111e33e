// Continuity end to end (deterministic SlamSystem on synthetic scenes with exact ground truth):
// a covered camera, a start hidden behind a moving object, sudden jumps. Tracking may lose the
// camera; it must come back within a few frames, in the old map or in a new one that place
// recognition merges into the old one, so that (almost) every frame ends up with a pose in one
// world.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "eval/metrics.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"
#include "system/slam_system.hpp"
#include "system_support.hpp"
#include "support/temp_dir.hpp"

namespace desslam {
namespace {

struct AtlasRun {
  Trajectory main_map;     // CameraTrajectory.txt
  AtlasTrajectory all;     // CameraTrajectory_all.txt
  nlohmann::json statistics;
  std::vector<bool> tracked;    // per frame given to the system
  std::vector<bool> predicted;  // ... given the motion prediction as its pose
  nlohmann::json dense;         // exportDenseMap's summary, when options.dense.enabled
  // Per frame given to the system, as processFrame left it: its pose in its map's world, and in
  // the odometry frame (nullopt: no pose).
  std::vector<std::optional<AtlasPose>> live;
  std::vector<std::optional<SE3>> odometry;
};

// Frames of `path` rendered in `scene` and fed in order; `edit(i, frame)` may change frame i,
// `skip(i)` withholds it.
template <class Edit, class Skip>
AtlasRun runAtlas(const sim::SyntheticScene& scene, const Trajectory& path, const SystemOptions& options, Edit edit,
                  Skip skip, bool deterministic = true) {
  system::RunSettings settings;
  settings.deterministic = deterministic;
  system::SlamSystem slam(options, settings);
  std::vector<std::optional<AtlasPose>> live;
  std::vector<std::optional<SE3>> odometry;
  for (size_t i = 0; i < path.size(); ++i) {
    if (skip(i)) continue;
    sim::RenderedFrame image = scene.render(path[i].T_w_c, path[i].timestamp);
    edit(i, image);
    slam.processFrame(path[i].timestamp, image.bgr, image.depth, "frame" + std::to_string(i));
    live.push_back(slam.lastFramePose());
    odometry.push_back(slam.lastOdometryPose());
  }
  slam.finish();
  AtlasRun run{slam.cameraTrajectory(), slam.cameraTrajectoryAll(), slam.statistics(), {}, {}, {}, live, odometry};
  if (options.dense.enabled) {
    const test::TempDir out;
    run.dense = slam.exportDenseMap(out.path(), false);
  }
  for (const system::FrameStats& f : slam.frameStats()) {
    run.tracked.push_back(f.tracked);
    run.predicted.push_back(f.predicted);
  }
  return run;
}

// runAtlas() edits: frames first..last are black with no depth (a covered lens).
auto coveredLens(size_t first, size_t last) {
  return [first, last](size_t i, sim::RenderedFrame& f) {
    if (i < first || i > last) return;
    f.bgr.setTo(cv::Scalar::all(0));
    f.depth.setTo(0.0f);
  };
}
bool noFrameWithheld(size_t) { return false; }

// Frames first..last-1 of `path` that have a pose in the main map, and the worst of their errors in
// the world of the whole run (aligned as `ate` aligned every frame).
struct FramesInMainMap {
  size_t count = 0;
  double worst_m = 0;
};
FramesInMainMap framesInMainMap(const Trajectory& path, const AtlasRun& run, const eval::AteResult& ate, size_t first,
                                size_t last) {
  FramesInMainMap result;
  for (const StampedPose& p : run.main_map)
    for (size_t i = first; i < last; ++i)
      if (path[i].timestamp == p.timestamp) {
        ++result.count;
        const Vec3 aligned = ate.T_gt_est * p.T_w_c.translation();
        result.worst_m = std::max(result.worst_m, (aligned - path[i].T_w_c.translation()).norm());
      }
  return result;
}

// Between consecutive frames both tracked (run.tracked; no frame withheld), the largest difference
// from the path's own step T_prev_now (translation; rotation angle): in the odometry frame, and for
// the poses processFrame gave in their maps' worlds (which jump where the world of the frame's map
// changes: a merge). Also how many frames had a pose in each.
struct StepErrors {
  double odometry_m = 0, odometry_deg = 0;
  double live_m = 0, live_deg = 0;
  size_t steps = 0;
  size_t live_posed = 0, odometry_posed = 0;
};
StepErrors trackedStepErrors(const Trajectory& path, const AtlasRun& run) {
  StepErrors e;
  for (size_t i = 0; i < run.live.size(); ++i) {
    e.live_posed += run.live[i].has_value();
    e.odometry_posed += run.odometry[i].has_value();
    if (i == 0 || !run.tracked[i - 1] || !run.tracked[i] || !run.live[i - 1] || !run.live[i] || !run.odometry[i - 1] ||
        !run.odometry[i])
      continue;
    const SE3 truth = path[i - 1].T_w_c.inverse() * path[i].T_w_c;
    const auto compare = [&](const SE3& before, const SE3& after, double& worst_m, double& worst_deg) {
      const SE3 difference = truth.inverse() * (before.inverse() * after);
      worst_m = std::max(worst_m, difference.translation().norm());
      worst_deg = std::max(worst_deg, difference.rotationAngle() * 180 / M_PI);
    };
    compare(*run.odometry[i - 1], *run.odometry[i], e.odometry_m, e.odometry_deg);
    compare(run.live[i - 1]->T_w_c, run.live[i]->T_w_c, e.live_m, e.live_deg);
    ++e.steps;
  }
  return e;
}

size_t liveMaps(const nlohmann::json& statistics) {
  size_t live = 0;
  for (const auto& m : statistics["atlas"]["maps"]) live += m["live"].get<bool>() && m["frames"].get<size_t>() > 0;
  return live;
}

// The bound on the ATE of the tracked frames of a run with a second map merged back. With local
// mapping in its thread, how far a lap keyframe had been refined when it was culled (after its own
// local bundle adjustment, which a waiting keyframe cuts short) depends on thread timing, and a
// culled keyframe whose parent is the map's fixed first keyframe keeps that pose, as do the frames
// referring to it (CoveredCameraMergeWithMappingAndLoopThreads: deterministic 5.0 mm; threaded
// 3.6-8.1 mm in 25 runs, and 4.4-10.8 mm in 10 runs under ThreadSanitizer, 3 of them over 10 mm).
double trackedAteBoundM(bool deterministic) { return deterministic ? 0.01 : 0.015; }

// 0-89: a lap facing the mapped side; 90-119: covered (coveredLens); 120-149: facing the other
// side; 150-239: turning back (90 degrees a second); 240-269: the first lap's start again.
constexpr size_t kTurnCoverFirst = 90, kTurnCoverLast = 119, kTurnedBack = 240, kCoverTurnFrames = 270;
Trajectory coverTurnAndComeBackPath(double fps) {
  constexpr double kPi = 3.14159265358979323846;
  const Trajectory lap = sim::loopPath(90, fps, 1);
  Trajectory path(lap.begin(), lap.end());
  const Vec3 start = lap.front().T_w_c.translation();
  const double pitch = -0.21;
  for (size_t i = path.size(); i < kCoverTurnFrames; ++i) {
    const double t = lap.front().timestamp + i / fps;
    double yaw = kPi;
    if (i >= 150 && i < kTurnedBack) yaw = kPi * (1.0 - (i - 150) / 90.0);
    if (i >= kTurnedBack) yaw = 0;
    path.push_back({t, i >= kTurnedBack ? lap[i - kTurnedBack].T_w_c : SE3(sim::lookRotation(yaw, pitch, 0.0), start)});
  }
  return path;
}

// The camera maps one side of the room, is covered (black, no depth) for one second while it
// turns round, and is uncovered facing the other side, which no keyframe saw: nothing to
// relocalise against, so tracking must start a second map at once. It then turns back to the
// mapped side, where place recognition must merge the second map into the first: in the end
// every uncovered frame has a pose in one world, as accurate as an uninterrupted run.
void coveredCameraStartsASecondMapThatIsMergedBack(bool deterministic) {
  SystemOptions options = test::syntheticSystemOptions();
  options.atlas.other_map_search_s = 0;  // place recognition's merge (tracking's: the test below)
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const double fps = options.camera.fps;
  constexpr size_t kFrames = kCoverTurnFrames;
  const Trajectory path = coverTurnAndComeBackPath(fps);
  const AtlasRun run =
      runAtlas(scene, path, options, coveredLens(kTurnCoverFirst, kTurnCoverLast), noFrameWithheld, deterministic);
  const nlohmann::json& atlas = run.statistics["atlas"];
  const eval::AteResult ate = eval::computeAte(path, run.main_map);
  std::printf("covered 1 s: %zu of %zu frames in the main map, maps started %d, merges %d, ATE %.2f mm\n%s\n",
              run.main_map.size(), kFrames, atlas["maps_started"].get<int>(), atlas["merges"].get<int>(),
              1000 * ate.translation_m.rmse, atlas.dump().c_str());
  EXPECT_GE(atlas["maps_started"].get<int>(), 2) << "a second map after the cover";
  EXPECT_GE(atlas["merges"].get<int>(), 1);
  EXPECT_EQ(liveMaps(run.statistics), 1u);
  // Every frame has a pose in the one world: the first frames of the cover get the motion
  // prediction (tracking.predict_through_loss_s); once the merge has brought the second map into
  // the first, the rest are interpolated between the last predicted and the first tracked one
  // (Tracker::interpolateAcrossMerges).
  EXPECT_EQ(run.main_map.size(), kFrames);
  EXPECT_GT(run.statistics["counts"]["interpolated_poses"].get<int>(), 0);
  for (size_t i = kTurnCoverLast + 1; i < kTurnCoverLast + 4; ++i) EXPECT_TRUE(run.tracked[i]) << "frame " << i;
  const int predicted = run.statistics["counts"]["predicted_poses"].get<int>();
  EXPECT_GT(predicted, 0);
  EXPECT_LE(predicted, static_cast<int>(options.tracking.predict_through_loss_s * fps) + 1);
  for (size_t i = 0; i < run.predicted.size(); ++i)
    if (run.predicted[i]) {
      EXPECT_TRUE(i >= kTurnCoverFirst && i <= kTurnCoverLast) << "frame " << i;
    }
  // Accuracy of the tracked frames (the predicted ones are dead reckoning through a black view).
  Trajectory tracked;
  for (const StampedPose& p : run.main_map)
    for (size_t i = 0; i < path.size(); ++i)
      if (path[i].timestamp == p.timestamp && run.tracked[i]) tracked.push_back(p);
  const eval::AteResult tracked_ate = eval::computeAte(path, tracked);
  std::printf("ATE over the %zu tracked frames %.2f mm (all %.2f mm)\n", tracked.size(),
              1000 * tracked_ate.translation_m.rmse, 1000 * ate.translation_m.rmse);
  EXPECT_LT(tracked_ate.translation_m.rmse, trackedAteBoundM(deterministic));
  // All frames, the 30 covered ones too: those are guesses (the camera turned round unseen).
  EXPECT_LT(ate.translation_m.rmse, 0.04);

  // The odometry frame: a pose whenever a frame had one, and between tracked frames the step the
  // camera made, where the poses in the maps' worlds jump as the merge moves the second map.
  const StepErrors steps = trackedStepErrors(path, run);
  std::printf("steps between tracked frames (%zu): largest error %.2f mm / %.2f deg in the odometry frame, %.1f mm / "
              "%.1f deg in the maps' worlds; %zu frames with a pose, %zu in the odometry frame, %d steps extrapolated\n",
              steps.steps, 1000 * steps.odometry_m, steps.odometry_deg, 1000 * steps.live_m, steps.live_deg,
              steps.live_posed, steps.odometry_posed,
              run.statistics["counts"]["odometry_frame_extrapolated_steps"].get<int>());
  // The second map's world is the camera's at its start, turned half round from the first's: the
  // merge turns the poses in the maps' worlds by that. The odometry frame's steps keep tracking's
  // own step error (12 mm while the camera turns on the spot; 22 and 25 mm in two runs with threads).
  EXPECT_EQ(steps.odometry_posed, steps.live_posed);
  EXPECT_GT(steps.live_deg, 90.0) << "the merge moves the second map's frames into the first map's world";
  EXPECT_LT(steps.odometry_deg, 2.0);
  EXPECT_LT(steps.odometry_m, 0.04);
  EXPECT_GE(run.statistics["counts"]["odometry_frame_extrapolated_steps"].get<int>(), 1) << "the second map's start";
}

TEST(SystemAtlas, CoveredCameraStartsASecondMapThatIsMergedBack) { coveredCameraStartsASecondMapThatIsMergedBack(true); }

// The same with local mapping and loop closing in their threads: the merge moves the second map
// while tracking goes on (Map::worldGate; run under ThreadSanitizer too).
TEST(SystemAtlas, CoveredCameraMergeWithMappingAndLoopThreads) { coveredCameraStartsASecondMapThatIsMergedBack(false); }

// The same path with a cover of 0.3 s: the camera turns round at once as the cover starts. The
// covered frames get the prediction from the lap before (tracking.predict_through_loss_s), which
// goes on along the lap while the camera stands. After the cover the camera faces the side no
// keyframe saw: a second map starts there (its first frames tracked backwards from its start) and
// is merged into the first when the camera comes back. In one world at the end, the covered frames
// lie between the last frame tracked before the cover and the first after it
// (tracking.interpolate_predictions_within_s); without that they keep the prediction.
void predictionsAcrossAMergedLossAreInterpolated(bool interpolate) {
  constexpr size_t kCoverLast = kTurnCoverFirst + 8;
  SystemOptions options = test::syntheticSystemOptions();
  if (!interpolate) options.tracking.interpolate_predictions_within_s = 0;
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = coverTurnAndComeBackPath(options.camera.fps);
  const AtlasRun run = runAtlas(scene, path, options, coveredLens(kTurnCoverFirst, kCoverLast), noFrameWithheld);
  const eval::AteResult ate = eval::computeAte(path, run.main_map);
  const auto [covered_in_main, worst_m] = framesInMainMap(path, run, ate, kTurnCoverFirst, kCoverLast + 1);
  const nlohmann::json& counts = run.statistics["counts"];
  std::printf("0.3 s cover, interpolation %s: maps started %d, merges %d, %zu of %zu frames in the main map, covered "
              "frames: %zu in the main map, predicted %d, interpolated %d, worst %.1f mm, ATE %.2f mm\n",
              interpolate ? "on" : "off", run.statistics["atlas"]["maps_started"].get<int>(),
              run.statistics["atlas"]["merges"].get<int>(), run.main_map.size(), path.size(), covered_in_main,
              counts["predicted_poses"].get<int>(), counts["interpolated_poses"].get<int>(), 1000 * worst_m,
              1000 * ate.translation_m.rmse);
  ASSERT_GE(run.statistics["atlas"]["maps_started"].get<int>(), 2) << "a second map after the cover";
  ASSERT_EQ(liveMaps(run.statistics), 1u) << "merged by the end";
  // The second map starts within a few frames (the first views of that side have too few features
  // spread over the image) and the frames before its start are tracked backwards from it.
  size_t first_tracked = kCoverLast + 1;
  while (first_tracked < path.size() && !run.tracked[first_tracked]) ++first_tracked;
  EXPECT_LE(first_tracked, kCoverLast + 10);
  EXPECT_FALSE(run.predicted[kCoverLast + 1]);
  EXPECT_EQ(run.main_map.size(), path.size());
  for (size_t i = kTurnCoverFirst; i <= kCoverLast; ++i) EXPECT_TRUE(run.predicted[i]) << "frame " << i;
  EXPECT_EQ(covered_in_main, kCoverLast - kTurnCoverFirst + 1);
  if (interpolate) {
    EXPECT_GE(counts["interpolated_poses"].get<int>(), static_cast<int>(kCoverLast - kTurnCoverFirst + 1));
    EXPECT_LT(worst_m, 0.03);
  } else {
    EXPECT_GT(worst_m, 0.05) << "the prediction goes on along the lap";
  }
}

TEST(SystemAtlas, PredictionsAcrossAMergedLossAreInterpolated) { predictionsAcrossAMergedLossAreInterpolated(true); }
TEST(SystemAtlas, PredictionsAcrossAMergedLossStayWithoutInterpolation) {
  predictionsAcrossAMergedLossAreInterpolated(false);
}

// The same path, but place recognition cannot merge maps while keyframes arrive
// (atlas.merge_min_consistent_keyframes out of reach):
// - kTracking: the second map, started after the cover, is merged because tracking finds the
//   camera in the first map too as it turns back, within atlas.other_map_search_s of that map's
//   start (here long enough to cover the turn), at two frames that agree on the transform;
// - kEndOfRunSearch: without that search, the maps are merged at the end of the run, when every
//   keyframe of the second map is searched for in the first (atlas.final_merge_search);
// - kNothing: without either, the two maps stay apart.
// Every frame merged then has a pose in one world, as accurate as with place recognition online.
enum class MergedBy { kTracking, kEndOfRunSearch, kNothing };
void secondMapIsMergedWithoutPlaceRecognitionOnline(MergedBy by, bool deterministic) {
  SystemOptions options = test::syntheticSystemOptions();
  options.atlas.merge_min_consistent_keyframes = 100;
  options.atlas.other_map_search_s = by == MergedBy::kTracking ? 5.0 : 0.0;
  options.atlas.final_merge_search = by == MergedBy::kEndOfRunSearch;
  options.dense.enabled = true;  // the dense map must follow every merge, the last ones too
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = coverTurnAndComeBackPath(options.camera.fps);
  const AtlasRun run =
      runAtlas(scene, path, options, coveredLens(kTurnCoverFirst, kTurnCoverLast), noFrameWithheld, deterministic);
  const nlohmann::json& atlas = run.statistics["atlas"];
  const int by_tracking = run.statistics["loop_closing"]["merges_found_by_tracking"].get<int>();
  const int at_end = run.statistics["loop_closing"]["merges_at_end"].get<int>();
  std::printf("%zu of %zu frames in the main map, found in the other map %d, merges %d (by tracking %d, at the end %d)\n%s\n",
              run.main_map.size(), kCoverTurnFrames, run.statistics["counts"]["found_in_other_map"].get<int>(),
              atlas["merges"].get<int>(), by_tracking, at_end, atlas.dump().c_str());
  ASSERT_GE(atlas["maps_started"].get<int>(), 2) << "a second map after the cover";
  const size_t with_pose = run.statistics["counts"]["frames_with_pose"].get<size_t>();
  if (by == MergedBy::kNothing) {
    EXPECT_EQ(atlas["merges"].get<int>(), 0);
    EXPECT_EQ(liveMaps(run.statistics), 2u);
    EXPECT_LT(run.main_map.size(), kCoverTurnFrames - 100);
    // The other map's frames are counted apart from the main map's (the run warns of them).
    EXPECT_EQ(atlas["frames_in_main_map"].get<size_t>(), run.main_map.size());
    EXPECT_EQ(atlas["frames_outside_main_map"].get<size_t>(), with_pose - run.main_map.size());
    EXPECT_GE(atlas["frames_outside_main_map"].get<size_t>(), 100u);
    ASSERT_EQ(atlas["maps_apart_from_main"].size(), 1u);
    EXPECT_NE(atlas["maps_apart_from_main"][0]["id"].get<int>(), atlas["main_map"].get<int>());
    EXPECT_EQ(atlas["maps_apart_from_main"][0]["frames"], atlas["frames_outside_main_map"]);
    return;
  }
  EXPECT_EQ(atlas["frames_outside_main_map"].get<size_t>(), 0u);
  EXPECT_TRUE(atlas["maps_apart_from_main"].empty());
  if (by == MergedBy::kTracking) {
    EXPECT_GE(by_tracking, 1);
    EXPECT_EQ(at_end, 0);
  } else {
    EXPECT_EQ(by_tracking, 0);
    EXPECT_EQ(at_end, 1);
  }
  EXPECT_EQ(liveMaps(run.statistics), 1u);
  EXPECT_EQ(run.main_map.size(), kCoverTurnFrames);
  // The second map's keyframes, held out of the dense map until the merge, are in it now.
  std::printf("dense map: %s\n", run.dense.dump().c_str());
  EXPECT_EQ(run.dense.value("keyframes_of_other_maps_left_out", -1), 0);
  Trajectory tracked;
  for (const StampedPose& p : run.main_map)
    for (size_t i = 0; i < path.size(); ++i)
      if (path[i].timestamp == p.timestamp && run.tracked[i]) tracked.push_back(p);
  const eval::AteResult tracked_ate = eval::computeAte(path, tracked);
  std::printf("ATE over the %zu tracked frames %.2f mm\n", tracked.size(), 1000 * tracked_ate.translation_m.rmse);
  EXPECT_GE(tracked.size(), kCoverTurnFrames - (kTurnCoverLast - kTurnCoverFirst + 1) - 3);
  EXPECT_LT(tracked_ate.translation_m.rmse, trackedAteBoundM(deterministic));
}

TEST(SystemAtlas, SecondMapIsMergedWhereTrackingFindsTheFirst) {
  secondMapIsMergedWithoutPlaceRecognitionOnline(MergedBy::kTracking, true);
}
TEST(SystemAtlas, SecondMapIsMergedWhereTrackingFindsTheFirstWithThreads) {
  secondMapIsMergedWithoutPlaceRecognitionOnline(MergedBy::kTracking, false);
}
TEST(SystemAtlas, SecondMapIsMergedByTheSearchAtTheEndOfTheRun) {
  secondMapIsMergedWithoutPlaceRecognitionOnline(MergedBy::kEndOfRunSearch, true);
}
TEST(SystemAtlas, SecondMapIsMergedByTheSearchAtTheEndOfTheRunWithThreads) {
  secondMapIsMergedWithoutPlaceRecognitionOnline(MergedBy::kEndOfRunSearch, false);
}
TEST(SystemAtlas, WithoutTheOtherMapSearchesTheSecondMapStaysApart) {
  secondMapIsMergedWithoutPlaceRecognitionOnline(MergedBy::kNothing, true);
}

// The camera maps one side of the room, is covered while it turns round, and starts a second map
// facing the other side (as above); then it is covered again while it turns back and is uncovered
// facing the first side, which only the first map holds. Relocalisation finds it there: tracking
// must go on in the first map, and the keyframe made at that frame belongs to it. (A keyframe that
// joined the lost map instead carried the first map's world into it: the rest of the run was
// tracked in the lost map, 1.6 m off, on an fr1_desk composite.)
TEST(SystemAtlas, RelocalisedIntoAnOlderMapTrackingGoesOnInThatMap) {
  const SystemOptions options = test::syntheticSystemOptions();
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  constexpr double kPi = 3.14159265358979323846;
  const double fps = options.camera.fps;
  // 0-89: a lap facing the mapped side; 90-119: covered; 120-179: facing the other side, moving
  // sideways 1 cm a frame (the second map grows past atlas.young_map_keyframes, so the tracker
  // stays in it when it is lost); 180-194: covered; 195-254: the first lap's start again.
  constexpr size_t kSecondFirst = 120, kSecondCoverFirst = 180, kBackFirst = 195, kFrames = 255;
  const Trajectory lap = sim::loopPath(90, fps, 1);
  Trajectory path(lap.begin(), lap.end());
  const Vec3 start = lap.front().T_w_c.translation();
  for (size_t i = path.size(); i < kFrames; ++i) {
    const double t = lap.front().timestamp + i / fps;
    const double sideways_m = i >= kSecondFirst && i < kSecondCoverFirst ? 0.01 * (i - kSecondFirst) : 0.0;
    path.push_back({t, i >= kBackFirst ? lap[i - kBackFirst].T_w_c
                                       : SE3(sim::lookRotation(kPi, -0.21, 0.0), start + Vec3(sideways_m, 0, 0))});
  }
  const auto first_cover = coveredLens(90, 119);
  const auto second_cover = coveredLens(kSecondCoverFirst, kBackFirst - 1);
  const auto covered = [&](size_t i, sim::RenderedFrame& f) {
    first_cover(i, f);
    second_cover(i, f);
  };
  const AtlasRun run = runAtlas(scene, path, options, covered, noFrameWithheld);
  const nlohmann::json& atlas = run.statistics["atlas"];
  std::printf("relocalised into the first map: %zu of %zu frames in the main map, relocalisations %d\n%s\n",
              run.main_map.size(), kFrames, run.statistics["counts"]["relocalisations"].get<int>(),
              atlas.dump().c_str());
  ASSERT_GE(atlas["maps_started"].get<int>(), 2) << "a second map facing the other side";
  // Every frame tracked after the second cover lies in the first frame's map, and is accurate.
  int first_map = -1;
  for (const AtlasPose& p : run.all)
    if (p.timestamp == path.front().timestamp) first_map = p.world_map;
  ASSERT_GE(first_map, 0);
  size_t tracked_back = 0, in_first_map = 0;
  for (size_t i = kBackFirst; i < kFrames; ++i) {
    if (!run.tracked[i]) continue;
    ++tracked_back;
    for (const AtlasPose& p : run.all) in_first_map += p.timestamp == path[i].timestamp && p.world_map == first_map;
  }
  EXPECT_GE(tracked_back, kFrames - kBackFirst - 3);
  ASSERT_EQ(in_first_map, tracked_back) << "frames tracked after the return but not in the first map";
  // The tracked frames of the first lap and of the return, aligned together: one world.
  Trajectory tracked;
  for (const StampedPose& p : run.main_map)
    for (size_t i = 0; i < path.size(); ++i)
      if (path[i].timestamp == p.timestamp && run.tracked[i] && (i < 90 || i >= kBackFirst)) tracked.push_back(p);
  const eval::AteResult ate = eval::computeAte(path, tracked);
  std::printf("%zu frames tracked after the second cover, all in the first map; ATE over %zu tracked frames %.2f mm\n",
              tracked_back, tracked.size(), 1000 * ate.translation_m.rmse);
  EXPECT_EQ(tracked.size(), 90 + tracked_back);
  EXPECT_LT(ate.translation_m.rmse, 0.01);
}

// runAtlas() edit: frames first..first+count-1 show a random-textured board 0.6 m from the camera,
// filling the view and sliding 4 px per frame.
auto boardInFront(const CameraOptions& camera, size_t first, size_t count) {
  cv::Mat board(camera.height, camera.width + 4 * static_cast<int>(count), CV_8UC3);
  cv::RNG rng(7);
  cv::Mat small(board.rows / 8, board.cols / 8, CV_8UC3);
  rng.fill(small, cv::RNG::UNIFORM, 0, 255);
  cv::resize(small, board, board.size(), 0, 0, cv::INTER_NEAREST);
  return [board, first, count](size_t i, sim::RenderedFrame& f) {
    if (i < first || i >= first + count) return;
    board(cv::Rect(static_cast<int>(i - first) * 4, 0, f.bgr.cols, f.bgr.rows)).copyTo(f.bgr);
    f.depth.setTo(0.6f);
  };
}

// A textured board close to the camera fills the whole view for the first half second (moving
// slowly), then is gone. Without masks (geometric mode) nothing says the board is not the world,
// so the first map is made of it; when the board goes, that young map is lost and a new one must
// start at once, so that every frame after the board is tracked in one accurate world.
TEST(SystemAtlas, StartHiddenByAMovingBoardDoesNotStarveTheMap) {
  constexpr int kFrames = 120;
  constexpr int kBoardFrames = 15;
  const SystemOptions options = test::syntheticSystemOptions();
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = sim::sweepPath(kFrames, options.camera.fps);
  const AtlasRun run = runAtlas(scene, path, options, boardInFront(options.camera, 0, kBoardFrames), noFrameWithheld);
  const eval::AteResult ate = eval::computeAte(path, run.main_map);
  size_t after_board = 0, during_board = 0;
  for (const StampedPose& p : run.main_map) {
    after_board += p.timestamp >= path[kBoardFrames].timestamp;
    during_board += p.timestamp < path[kBoardFrames].timestamp;
  }
  std::printf("board start: %zu of %d frames in the main map (%zu of %d after the board), maps started %d, ATE %.2f mm\n",
              run.main_map.size(), kFrames, after_board, kFrames - kBoardFrames,
              run.statistics["atlas"]["maps_started"].get<int>(), 1000 * ate.translation_m.rmse);
  EXPECT_GE(after_board, static_cast<size_t>(kFrames - kBoardFrames - 3));
  EXPECT_EQ(during_board, 0u) << "the board's frames are not in the world's trajectory";
  EXPECT_GE(run.statistics["atlas"]["maps_started"].get<int>(), 2);
  EXPECT_LT(ate.translation_m.rmse, 0.01);
}

// Mid-run the same board fills the view for half a second (nothing masks it: geometric mode) and
// tracking loses the camera. A map started on the board would track the board (a person filling
// the view whom the network misses does the same). The first map's keyframe saw the room behind
// it: a new map starting within atlas.start_free_space_check_s of the loss drops the features in
// that free space, so none starts on the board, and the camera is found again in the first map
// once the board is gone. With the check off, a map starts on the board.
void boardInFrontMidRun(bool check) {
  constexpr size_t kFrames = 120, kBoardFirst = 50, kBoardFrames = 15;
  SystemOptions options = test::syntheticSystemOptions();
  if (!check) options.atlas.start_free_space_check_s = 0;
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = sim::sweepPath(kFrames, options.camera.fps);
  const AtlasRun run =
      runAtlas(scene, path, options, boardInFront(options.camera, kBoardFirst, kBoardFrames), noFrameWithheld);
  const int maps_started = run.statistics["atlas"]["maps_started"].get<int>();
  size_t board_tracked = 0;
  for (size_t i = kBoardFirst; i < kBoardFirst + kBoardFrames; ++i) board_tracked += run.tracked[i];
  const eval::AteResult ate = eval::computeAte(path, run.main_map);
  std::printf("board mid-run, check %s: maps started %d, %zu board frames tracked, %zu of %zu frames in the main "
              "map, ATE %.2f mm\n",
              check ? "on" : "off", maps_started, board_tracked, run.main_map.size(), kFrames,
              1000 * ate.translation_m.rmse);
  if (!check) {
    EXPECT_GE(maps_started, 2) << "without the check a map starts on the board";
    EXPECT_GT(board_tracked, 0u);
    return;
  }
  EXPECT_EQ(maps_started, 1) << "no map on the board";
  EXPECT_EQ(board_tracked, 0u);
  for (size_t i = kBoardFirst + kBoardFrames + 3; i < kFrames; ++i) EXPECT_TRUE(run.tracked[i]) << "frame " << i;
  EXPECT_GE(run.main_map.size(), kFrames - kBoardFrames);
  EXPECT_LT(ate.translation_m.rmse, 0.01);
}
TEST(SystemAtlas, NoMapStartsOnABoardInFrontOfTheMappedRoom) { boardInFrontMidRun(true); }
TEST(SystemAtlas, WithoutTheFreeSpaceCheckAMapStartsOnTheBoard) { boardInFrontMidRun(false); }

// The first frames have depth only on a strip of the view (a crowd close to the camera, a depth
// camera still warming up): fewer static depth-backed features than a map needs
// (atlas.min_initial_features), so no map can start there. Once one starts, those frames are
// tracked backwards from it (tracking.backfill_max_s) and get accurate poses; without that they
// have none.
void firstFramesWithoutAMapStartAreBackfilled(bool backfill) {
  constexpr size_t kWithoutStart = 9, kFrames = 60;
  SystemOptions options = test::syntheticSystemOptions();
  // Without backfilling (nor the backward prediction and the held poses that would stand in for it).
  if (!backfill)
    options.tracking.backfill_max_s = options.tracking.predict_back_s = options.tracking.hold_pose_s = 0;
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = sim::sweepPath(kFrames, options.camera.fps);
  const AtlasRun run = runAtlas(
      scene, path, options,
      [&](size_t i, sim::RenderedFrame& f) {
        if (i >= kWithoutStart) return;
        f.depth(cv::Rect(0, 0, f.depth.cols * 3 / 4, f.depth.rows)).setTo(0.0f);
      },
      noFrameWithheld);
  const nlohmann::json& counts = run.statistics["counts"];
  const eval::AteResult ate = eval::computeAte(path, run.main_map);
  Trajectory first;
  for (const StampedPose& p : run.main_map)
    if (p.timestamp < path[kWithoutStart].timestamp) first.push_back(p);
  std::printf("backfill %s: %zu of %zu frames in the main map, %zu of the first %zu, backfilled %d, ATE %.2f mm\n",
              backfill ? "on" : "off", run.main_map.size(), kFrames, first.size(), kWithoutStart,
              counts["backfilled_poses"].get<int>(), 1000 * ate.translation_m.rmse);
  EXPECT_GE(run.statistics["atlas"]["initialisations_refused"].get<int>(), static_cast<int>(kWithoutStart))
      << "the strip alone must not start a map";
  for (size_t i = 0; i < kWithoutStart; ++i) EXPECT_FALSE(run.tracked[i]) << "frame " << i;
  if (!backfill) {
    EXPECT_TRUE(first.empty());
    EXPECT_EQ(counts["backfilled_poses"].get<int>(), 0);
    return;
  }
  EXPECT_EQ(first.size(), kWithoutStart);
  EXPECT_EQ(counts["backfilled_poses"].get<int>(), static_cast<int>(kWithoutStart));
  EXPECT_EQ(run.main_map.size(), kFrames);
  const eval::AteResult first_ate = eval::computeAte(path, first);
  std::printf("backfilled frames alone: ATE %.2f mm\n", 1000 * first_ate.translation_m.rmse);
  EXPECT_LT(ate.translation_m.rmse, 0.005);
}

TEST(SystemAtlas, FirstFramesWithoutAMapStartAreBackfilled) { firstFramesWithoutAMapStartAreBackfilled(true); }
TEST(SystemAtlas, FirstFramesWithoutAMapStartHaveNoPoseWithoutBackfill) {
  firstFramesWithoutAMapStartAreBackfilled(false);
}

// A sweep of `frames` frames whose first `covered` ones are black with no depth.
struct CoveredStartRun {
  AtlasRun run;
  eval::AteResult ate;
  FramesInMainMap covered;  // of the covered frames
};
CoveredStartRun runWithCoveredStart(const SystemOptions& options, size_t covered, size_t frames) {
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = sim::sweepPath(static_cast<int>(frames), options.camera.fps);
  CoveredStartRun result{runAtlas(scene, path, options, coveredLens(0, covered - 1), noFrameWithheld), {}, {}};
  result.ate = eval::computeAte(path, result.run.main_map);
  result.covered = framesInMainMap(path, result.run, result.ate, 0, covered);
  return result;
}

// The first frames are black with no depth (a lens cap, a person right in front of the camera)
// while the camera already sweeps: no feature search can reach them, from the map that starts
// after them either. They get the motion of the first frames tracked after them, extrapolated
// backwards (tracking.predict_back_s), as poses in that map; with it off they have none.
void coveredFirstFramesArePredictedBackwards(bool predict_back) {
  constexpr size_t kCovered = 7, kFrames = 40;
  SystemOptions options = test::syntheticSystemOptions();
  // Without it (nor the held poses at the end of the run that would stand in for it, tracking.hold_pose_s).
  if (!predict_back) options.tracking.predict_back_s = options.tracking.hold_pose_s = 0;
  const auto [run, ate, covered] = runWithCoveredStart(options, kCovered, kFrames);
  const auto [covered_with_pose, worst_m] = covered;
  const nlohmann::json& counts = run.statistics["counts"];
  std::printf("covered first frames, backward prediction %s: %zu of %zu with a pose, predicted backwards %d, "
              "worst %.1f mm, ATE %.2f mm\n", predict_back ? "on" : "off", covered_with_pose, kCovered,
              counts["backward_predicted_poses"].get<int>(), 1000 * worst_m, 1000 * ate.translation_m.rmse);
  for (size_t i = 0; i < kCovered; ++i) EXPECT_FALSE(run.tracked[i]) << "frame " << i;
  for (size_t i = kCovered; i < kFrames; ++i) EXPECT_TRUE(run.tracked[i]) << "frame " << i;
  if (!predict_back) {
    EXPECT_EQ(covered_with_pose, 0u);
    EXPECT_EQ(counts["backward_predicted_poses"].get<int>(), 0);
    return;
  }
  EXPECT_EQ(covered_with_pose, kCovered);
  EXPECT_EQ(counts["backward_predicted_poses"].get<int>(), static_cast<int>(kCovered));
  EXPECT_EQ(run.main_map.size(), kFrames);
  EXPECT_LT(worst_m, 0.015) << "the sweep's motion, extrapolated 0.23 s back";
  EXPECT_LT(ate.translation_m.rmse, 0.005);
}
TEST(SystemAtlas, CoveredFirstFramesArePredictedBackwards) { coveredFirstFramesArePredictedBackwards(true); }
TEST(SystemAtlas, CoveredFirstFramesHaveNoPoseWithoutBackwardPrediction) {
  coveredFirstFramesArePredictedBackwards(false);
}

// Frame i of `path` in `all` (null when it has no pose).
const AtlasPose* poseOf(const AtlasTrajectory& all, const Trajectory& path, size_t i) {
  for (const AtlasPose& p : all)
    if (p.timestamp == path[i].timestamp) return &p;
  return nullptr;
}
bool samePose(const AtlasPose* a, const AtlasPose* b) {
  return a != nullptr && b != nullptr && (a->T_w_c.inverse() * b->T_w_c).log().norm() < 1e-9;
}

// As above, but covered for longer than the backward prediction reaches (tracking.predict_back_s):
// at the end of the run the frames before it get the pose of the first frame that has one
// (tracking.hold_pose_s); with that off they have no pose.
void coveredFirstFramesBeyondTheBackwardPrediction(bool hold) {
  constexpr size_t kCovered = 16, kFrames = 50;
  SystemOptions options = test::syntheticSystemOptions();
  if (!hold) options.tracking.hold_pose_s = 0;
  const auto [run, ate, covered] = runWithCoveredStart(options, kCovered, kFrames);
  const auto [covered_with_pose, worst_m] = covered;
  const nlohmann::json& counts = run.statistics["counts"];
  const int backwards = counts["backward_predicted_poses"].get<int>();
  const int held = counts["held_poses"].get<int>();
  std::printf("%zu covered first frames, holding %s: %zu with a pose, predicted backwards %d, held %d, worst "
              "%.1f mm, ATE %.2f mm\n", kCovered, hold ? "on" : "off", covered_with_pose, backwards, held,
              1000 * worst_m, 1000 * ate.translation_m.rmse);
  for (size_t i = kCovered; i < kFrames; ++i) EXPECT_TRUE(run.tracked[i]) << "frame " << i;
  EXPECT_GT(backwards, 0);
  EXPECT_LT(backwards, static_cast<int>(kCovered));
  if (!hold) {
    EXPECT_EQ(held, 0);
    EXPECT_EQ(covered_with_pose, static_cast<size_t>(backwards));
    return;
  }
  EXPECT_EQ(covered_with_pose, kCovered);
  EXPECT_EQ(held, static_cast<int>(kCovered) - backwards);
  EXPECT_EQ(run.main_map.size(), kFrames);
  const Trajectory path = sim::sweepPath(kFrames, options.camera.fps);
  const size_t first_predicted = kCovered - backwards;
  for (size_t i = 0; i < first_predicted; ++i)
    EXPECT_TRUE(samePose(poseOf(run.all, path, i), poseOf(run.all, path, first_predicted))) << "frame " << i;
}
TEST(SystemAtlas, CoveredFirstFramesBeyondTheBackwardPredictionGetTheNearestPose) {
  coveredFirstFramesBeyondTheBackwardPrediction(true);
}
TEST(SystemAtlas, CoveredFirstFramesBeyondTheBackwardPredictionHaveNoPoseWithoutHolding) {
  coveredFirstFramesBeyondTheBackwardPrediction(false);
}

// A cover between two maps that stay apart (no merge: nothing to interpolate between): the first
// frames of the cover get the prediction from before it, the last ones the motion after it
// extrapolated backwards, and each frame between the two, beyond both horizons, gets the pose of
// the nearer of the two, in its map (tracking.hold_pose_s). A cover of one second lies within the
// holds' reach (0.3 s on either side); one of two seconds does not, and its middle frames get a
// pose only because they lie between two frames with one (tracking.hold_pose_between_poses).
void framesBetweenTwoMapsBeyondBothPredictions(size_t cover_last, bool hold_between_poses) {
  SystemOptions options = test::syntheticSystemOptions();
  options.atlas.merge_min_consistent_keyframes = 100;
  options.atlas.other_map_search_s = 0;
  options.atlas.final_merge_search = false;
  options.tracking.hold_pose_between_poses = hold_between_poses;
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = coverTurnAndComeBackPath(options.camera.fps);
  const AtlasRun run = runAtlas(scene, path, options, coveredLens(kTurnCoverFirst, cover_last), noFrameWithheld);
  const nlohmann::json& counts = run.statistics["counts"];
  const int forward = counts["predicted_poses"].get<int>();
  const int backwards = counts["backward_predicted_poses"].get<int>();
  const int held = counts["held_poses"].get<int>();
  std::printf("%.1f s cover between two maps, holding between poses %s: %zu of %zu frames with a pose, predicted %d, "
              "predicted backwards %d, held %d\n",
              (cover_last + 1 - kTurnCoverFirst) / options.camera.fps, hold_between_poses ? "on" : "off",
              run.all.size(), path.size(), forward, backwards, held);
  ASSERT_EQ(liveMaps(run.statistics), 2u) << "the maps stay apart";
  // The frames beyond both predictions, first..last.
  ASSERT_GT(forward, 0);
  ASSERT_GT(backwards, 0);
  const size_t first = kTurnCoverFirst + forward, last = cover_last - backwards;
  ASSERT_GT(last, first);
  const AtlasPose* before = poseOf(run.all, path, first - 1);
  const AtlasPose* after = poseOf(run.all, path, last + 1);
  ASSERT_TRUE(before != nullptr && after != nullptr);
  EXPECT_NE(before->map, after->map);
  const double hold_s = options.tracking.hold_pose_s;
  size_t beyond_holds = 0;
  for (size_t i = first; i <= last; ++i) {
    const double since_before_s = path[i].timestamp - path[first - 1].timestamp;
    const double until_after_s = path[last + 1].timestamp - path[i].timestamp;
    const bool within_hold = std::min(since_before_s, until_after_s) <= hold_s;  // as the tracker compares
    beyond_holds += !within_hold;
    const AtlasPose* pose = poseOf(run.all, path, i);
    if (!within_hold && !hold_between_poses) {
      EXPECT_EQ(pose, nullptr) << "frame " << i;
      continue;
    }
    EXPECT_TRUE(samePose(pose, since_before_s <= until_after_s ? before : after)) << "frame " << i;
  }
  if (hold_between_poses) {
    EXPECT_EQ(run.all.size(), path.size()) << "every frame has a pose";
    EXPECT_EQ(static_cast<size_t>(held), last - first + 1);
  } else {
    EXPECT_EQ(run.all.size() + beyond_holds, path.size());
    EXPECT_EQ(static_cast<size_t>(held) + beyond_holds, last - first + 1);
  }
  EXPECT_EQ(beyond_holds > 0, cover_last > kTurnCoverLast) << "only the longer cover outlasts the holds";
}
TEST(SystemAtlas, FramesBetweenTwoMapsBeyondBothPredictionsGetTheNearerPose) {
  framesBetweenTwoMapsBeyondBothPredictions(kTurnCoverLast, true);
}
TEST(SystemAtlas, FramesOfALongCoverBetweenTwoMapsAllGetTheNearerPose) {
  framesBetweenTwoMapsBeyondBothPredictions(kTurnCoverFirst + 59, true);
}
TEST(SystemAtlas, FramesOfALongCoverBeyondTheHoldsHaveNoPoseWithoutHoldingBetweenPoses) {
  framesBetweenTwoMapsBeyondBothPredictions(kTurnCoverFirst + 59, false);
}

// As above, but the lens is uncovered for one frame only before it is covered again (people
// crossing the view twice): a map starts there and is lost at once, with no motion yet to
// extrapolate. The first covered frames wait for the next frame tracked after the second cover
// and get their poses from the motion after it.
TEST(SystemAtlas, FramesBeforeAMapLostAtOnceWaitForTheNextFrameTracked) {
  constexpr size_t kFirstCover = 4, kOpen = 4, kSecondCoverLast = 7, kFrames = 40;
  SystemOptions options = test::syntheticSystemOptions();
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = sim::sweepPath(kFrames, options.camera.fps);
  const auto first_cover = coveredLens(0, kFirstCover - 1);
  const auto second_cover = coveredLens(kOpen + 1, kSecondCoverLast);
  const AtlasRun run = runAtlas(
      scene, path, options,
      [&](size_t i, sim::RenderedFrame& f) {
        first_cover(i, f);
        second_cover(i, f);
      },
      noFrameWithheld);
  const AtlasTrajectory& all = run.all;
  const nlohmann::json& counts = run.statistics["counts"];
  std::printf("a map lost at once: %zu of %zu frames with a pose, %zu in the main map, predicted backwards %d, "
              "interpolated %d\n", all.size(), kFrames, run.main_map.size(),
              counts["backward_predicted_poses"].get<int>(), counts["interpolated_poses"].get<int>());
  EXPECT_TRUE(run.tracked[kOpen]) << "a map starts at the open frame";
  for (size_t i = kOpen + 1; i <= kSecondCoverLast; ++i) EXPECT_FALSE(run.tracked[i]) << "frame " << i;
  EXPECT_EQ(all.size(), kFrames) << "every frame has a pose, the first covered ones too";
  EXPECT_GE(counts["backward_predicted_poses"].get<int>(), static_cast<int>(kFirstCover));
  // The covered first frames, in the world of the map they were predicted in, against the truth.
  const eval::AteResult ate = eval::computeAte(path, run.main_map);
  const auto [first_with_pose, worst_m] = framesInMainMap(path, run, ate, 0, kFirstCover);
  std::printf("first covered frames in the main map: %zu, worst %.1f mm, ATE %.2f mm\n", first_with_pose,
              1000 * worst_m, 1000 * ate.translation_m.rmse);
  EXPECT_EQ(first_with_pose, kFirstCover);
  EXPECT_LT(worst_m, 0.02);
}

// The lens is covered (black, no depth) for 0.23 s while the camera doubles its speed: the frames
// of the cover get the motion before it as their pose (tracking.predict_through_loss_s), which
// falls behind. Once the camera is found again in the same map, they lie on the motion between
// the last frame tracked before the cover and the first after it (interpolated).
void coveredFramesAreSettledBetweenTheTrackedOnes(bool settle) {
  constexpr size_t kCoverFirst = 40, kCoverLast = 46, kFrames = 90;
  SystemOptions options = test::syntheticSystemOptions();
  if (!settle) {
    options.tracking.backfill_max_s = 0;
    options.tracking.interpolate_predictions_within_s = 0;  // the same interpolation at the end
  }
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory dense = sim::sweepPath(2 * kFrames, options.camera.fps);
  Trajectory path;
  for (size_t i = 0; i < kFrames; ++i) {
    const size_t k = i < kCoverFirst ? i : kCoverFirst + 2 * (i - kCoverFirst);  // twice as fast from the cover on
    path.push_back({dense[i].timestamp, dense[k].T_w_c});
  }
  const AtlasRun run = runAtlas(scene, path, options, coveredLens(kCoverFirst, kCoverLast), noFrameWithheld);
  Trajectory covered;
  for (const StampedPose& p : run.main_map)
    if (p.timestamp >= path[kCoverFirst].timestamp && p.timestamp <= path[kCoverLast].timestamp) covered.push_back(p);
  // The covered frames' error in the world of the whole run (aligned on every frame).
  const eval::AteResult ate = eval::computeAte(path, run.main_map);
  double worst_m = 0;
  for (const StampedPose& p : covered)
    for (size_t i = kCoverFirst; i <= kCoverLast; ++i)
      if (path[i].timestamp == p.timestamp) {
        const Vec3 aligned = ate.T_gt_est * p.T_w_c.translation();
        worst_m = std::max(worst_m, (aligned - path[i].T_w_c.translation()).norm());
      }
  const nlohmann::json& counts = run.statistics["counts"];
  std::printf("cover with settling %s: %zu of %zu covered frames in the main map, interpolated %d, worst %.1f mm, "
              "ATE %.2f mm\n", settle ? "on" : "off", covered.size(), kCoverLast - kCoverFirst + 1,
              counts["interpolated_poses"].get<int>(), 1000 * worst_m, 1000 * ate.translation_m.rmse);
  for (size_t i = kCoverLast + 1; i < kCoverLast + 4; ++i) EXPECT_TRUE(run.tracked[i]) << "frame " << i;
  EXPECT_EQ(run.main_map.size(), kFrames);
  EXPECT_EQ(liveMaps(run.statistics), 1u);
  for (size_t i = kCoverFirst; i <= kCoverLast; ++i) EXPECT_FALSE(run.tracked[i]) << "frame " << i;
  if (settle) {
    EXPECT_EQ(counts["interpolated_poses"].get<int>(), static_cast<int>(kCoverLast - kCoverFirst + 1));
    EXPECT_LT(worst_m, 0.015);
  } else {
    EXPECT_EQ(counts["interpolated_poses"].get<int>(), 0);
    EXPECT_GT(worst_m, 0.03) << "the prediction alone should fall behind the doubled speed";
  }
}

TEST(SystemAtlas, CoveredFramesAreInterpolatedBetweenTheTrackedOnes) { coveredFramesAreSettledBetweenTheTrackedOnes(true); }
TEST(SystemAtlas, CoveredFramesKeepThePredictionWithoutSettling) { coveredFramesAreSettledBetweenTheTrackedOnes(false); }

// The lens is covered for longer than the bridge lasts, a textured board then fills the view for
// two frames (a map starts on it and is lost again; its bridge covers the frames after it), the
// lens is covered again, and the camera comes back to the mapped room. The frames left without a
// pose before the board lie between the first map's last bridged frame and its first frame found
// again: they are interpolated in it, across the board map's frames, which keep their own poses.
// Without interpolation they have none.
void framesAroundAShortLivedMapAreInterpolated(bool interpolate) {
  constexpr size_t kCoverFirst = 50, kBoardFirst = 70, kBoardFrames = 2, kBackFirst = 78, kFrames = 120;
  SystemOptions options = test::syntheticSystemOptions();
  options.atlas.start_free_space_check_s = 0;  // the board map must start
  if (!interpolate) options.tracking.backfill_max_s = 0;
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = sim::sweepPath(kFrames, options.camera.fps);
  const auto cover_before = coveredLens(kCoverFirst, kBoardFirst - 1);
  const auto board = boardInFront(options.camera, kBoardFirst, kBoardFrames);
  const auto cover_after = coveredLens(kBoardFirst + kBoardFrames, kBackFirst - 1);
  const auto edit = [&](size_t i, sim::RenderedFrame& f) {
    cover_before(i, f);
    board(i, f);
    cover_after(i, f);
  };
  const AtlasRun run = runAtlas(scene, path, options, edit, noFrameWithheld);
  const eval::AteResult ate = eval::computeAte(path, run.main_map);
  // The frames covered before the board.
  const auto [covered_in_main, worst_m] = framesInMainMap(path, run, ate, kCoverFirst, kBoardFirst);
  const nlohmann::json& counts = run.statistics["counts"];
  std::printf("short-lived map, interpolation %s: maps started %d, %zu of %zu covered frames in the main map "
              "(interpolated %d, worst %.1f mm), %zu of %zu frames in the main map, ATE %.2f mm\n%s\n",
              interpolate ? "on" : "off", run.statistics["atlas"]["maps_started"].get<int>(), covered_in_main,
              kBoardFirst - kCoverFirst, counts["interpolated_poses"].get<int>(), 1000 * worst_m,
              run.main_map.size(), kFrames, 1000 * ate.translation_m.rmse, run.statistics["atlas"].dump().c_str());
  ASSERT_GE(run.statistics["atlas"]["maps_started"].get<int>(), 2) << "a map on the board";
  for (size_t i = kBackFirst + 3; i < kFrames; ++i) EXPECT_TRUE(run.tracked[i]) << "frame " << i;
  if (interpolate) {
    EXPECT_EQ(covered_in_main, kBoardFirst - kCoverFirst);
    EXPECT_LT(worst_m, 0.05);
  } else {
    EXPECT_LT(covered_in_main, kBoardFirst - kCoverFirst);
  }
}

TEST(SystemAtlas, FramesAroundAShortLivedMapAreInterpolated) { framesAroundAShortLivedMapAreInterpolated(true); }
TEST(SystemAtlas, FramesAroundAShortLivedMapHaveNoPoseWithoutInterpolation) {
  framesAroundAShortLivedMapAreInterpolated(false);
}

// Sudden jumps (frames withheld) at several places of the second lap: tracking resumes within a
// few frames after each, and by the end every frame is in one world.
TEST(SystemAtlas, JumpsAtSeveralPlacesAreRecoveredAndEndInOneMap) {
  constexpr int kFrames = 180;
  const SystemOptions options = test::syntheticSystemOptions();
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = sim::loopPath(kFrames, options.camera.fps, 2);
  for (const auto& [first, last] : std::vector<std::pair<size_t, size_t>>{{100, 129}, {135, 164}}) {
    const AtlasRun run = runAtlas(
        scene, path, options, [](size_t, sim::RenderedFrame&) {},
        [first = first, last = last](size_t i) { return i >= first && i <= last; });
    // The first frame after the gap is the system's frame number `first`.
    size_t resumed = 0;
    while (first + resumed < run.tracked.size() && !run.tracked[first + resumed]) ++resumed;
    const eval::AteResult ate = eval::computeAte(path, run.main_map);
    const size_t given = kFrames - (last - first + 1);
    std::printf("jump over %zu-%zu: resumed after %zu frames, %zu of %zu frames in the main map, ATE %.2f mm, %s\n",
                first, last, resumed, run.main_map.size(), given, 1000 * ate.translation_m.rmse,
                run.statistics["atlas"].dump().c_str());
    EXPECT_LE(resumed, 3u) << "gap " << first << "-" << last;
    EXPECT_EQ(liveMaps(run.statistics), 1u) << "gap " << first << "-" << last;
    EXPECT_GE(run.main_map.size(), given - 3) << "gap " << first << "-" << last;
    EXPECT_LT(ate.translation_m.rmse, 0.01) << "gap " << first << "-" << last;
  }
}

}  // namespace
}  // namespace desslam
