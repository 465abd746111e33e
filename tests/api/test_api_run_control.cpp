// What a program needs of desslam::Slam to run a whole sequence as `desslam run` does (which uses
// exactly these): finish() with stage callbacks and an abort flag, the final bundle adjustment's
// outcome, the dense-map export cut short, the trajectory files, debug images and emulated mask
// latency (RunMode). On the synthetic room.
#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include "desslam/desslam.hpp"
#include "io/trajectory_io.hpp"
#include "io/tum_dataset.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"
#include "api_support.hpp"
#include "support/temp_dir.hpp"
#include "system/system_support.hpp"

namespace desslam {
namespace {

constexpr int kFrames = 30;

using test::syntheticConfig;

void trackAll(Slam& slam, const io::TumSequence& sequence) {
  for (size_t i = 0; i < sequence.size(); ++i) {
    const io::RgbdImage image = sequence.load(i, slam.config().options().camera);
    slam.track(image.timestamp, image.bgr, image.depth, 0, sequence.record(i).rgb_path.filename().string());
  }
}

class ApiRunControlTest : public test::SyntheticSequenceTest<kFrames> {};

// The stages finish() announced, with on_stage answering `run_final_ba` at "final_ba".
struct Finished {
  std::vector<std::string> stages;
  bool final_ba_done = false;
};

Finished finishRun(const Config& config, const io::TumSequence& sequence, bool run_final_ba,
                   const std::atomic<bool>* abort = nullptr) {
  Slam slam(config, {.deterministic = true});
  trackAll(slam, sequence);
  EXPECT_FALSE(slam.finalBundleAdjustmentDone()) << "before finish()";
  Finished finished;
  FinishOptions options;
  options.abort = abort;
  options.on_stage = [&](const std::string& stage) {
    finished.stages.push_back(stage);
    return stage != "final_ba" || run_final_ba;
  };
  slam.finish(options);
  finished.final_ba_done = slam.finalBundleAdjustmentDone();
  return finished;
}

TEST_F(ApiRunControlTest, FinishAnnouncesItsStagesInOrderAndMaySkipTheFinalBundleAdjustment) {
  const std::vector<std::string> all = {"mapping", "final_ba", "dense"};
  const Finished full = finishRun(syntheticConfig(), sequence(), /*run_final_ba=*/true);
  EXPECT_EQ(full.stages, all);
  EXPECT_TRUE(full.final_ba_done);

  const Finished skipped = finishRun(syntheticConfig(), sequence(), /*run_final_ba=*/false);
  EXPECT_EQ(skipped.stages, all);
  EXPECT_FALSE(skipped.final_ba_done) << "on_stage returned false at final_ba";

  const std::atomic<bool> abort{true};
  const Finished aborted = finishRun(syntheticConfig(), sequence(), /*run_final_ba=*/true, &abort);
  EXPECT_EQ(aborted.stages, all);
  EXPECT_FALSE(aborted.final_ba_done) << "the abort flag was set";

  Config no_final_ba = syntheticConfig();
  no_final_ba.set("mapping.final_global_ba=false");
  const Finished off = finishRun(no_final_ba, sequence(), /*run_final_ba=*/true);
  EXPECT_EQ(off.stages, (std::vector<std::string>{"mapping", "dense"})) << "no final_ba stage when it is off";
  EXPECT_FALSE(off.final_ba_done);
}

TEST_F(ApiRunControlTest, AnAbortedDenseExportWritesNoFiles) {
  Config config = syntheticConfig();
  config.set("dense.enabled=true");
  Slam slam(config, {.deterministic = true});
  trackAll(slam, sequence());
  slam.finish();
  const test::TempDir out;
  const std::atomic<bool> abort{true};
  const nlohmann::json aborted = nlohmann::json::parse(slam.exportDenseMap(out.path() / "aborted", false, &abort));
  EXPECT_FALSE(aborted["exported"].get<bool>()) << aborted.dump();
  EXPECT_TRUE(std::filesystem::is_empty(out.path() / "aborted"));

  const nlohmann::json exported = nlohmann::json::parse(slam.exportDenseMap(out.path() / "full"));
  ASSERT_TRUE(exported["exported"].get<bool>()) << exported.dump();
  for (const char* file : {"dense_map.ply", "dense_map.pcd", "dense_map_sources.bin", "octomap.bt", "dense_map.png"})
    EXPECT_TRUE(std::filesystem::is_regular_file(out.path() / "full" / file)) << file;
}

// The OctoMap export reports its progress and looks at the abort flag while it runs: set during it
// (a second signal), the OctoMap and the PNG after it are skipped, the point cloud stays.
TEST_F(ApiRunControlTest, AnAbortDuringTheOctomapExportStopsIt) {
  Config config = syntheticConfig();
  config.set("dense.enabled=true");
  Slam slam(config, {.deterministic = true});
  trackAll(slam, sequence());
  slam.finish();
  const test::TempDir out;
  std::atomic<bool> abort{false};
  std::vector<std::string> files;
  std::vector<double> shares;
  const nlohmann::json j = nlohmann::json::parse(
      slam.exportDenseMap(out.path(), false, &abort, [&](const std::string& file, double share) {
        files.push_back(file);
        shares.push_back(share);
        if (shares.size() == 2) abort = true;
      }));
  EXPECT_EQ(shares.size(), 2u) << "stopped at the report after the flag was set";
  EXPECT_EQ(files, (std::vector<std::string>{"octomap.bt", "octomap.bt"}));
  EXPECT_TRUE(j["exported"].get<bool>()) << j.dump();
  EXPECT_EQ(j["skipped"], (nlohmann::json{"octomap.bt", "dense_map.png"})) << j.dump();
  EXPECT_TRUE(std::filesystem::is_regular_file(out.path() / "dense_map.ply"));
  EXPECT_FALSE(std::filesystem::exists(out.path() / "octomap.bt"));
  EXPECT_FALSE(std::filesystem::exists(out.path() / "dense_map.png"));
}

TEST_F(ApiRunControlTest, TrajectoryFilesHoldTheTrajectories) {
  Slam slam(syntheticConfig(), {.deterministic = true});
  trackAll(slam, sequence());
  slam.finish();
  const test::TempDir out;
  slam.writeTrajectory(out.path() / "CameraTrajectory.txt");
  slam.writeTrajectoryAll(out.path() / "CameraTrajectory_all.txt");
  slam.writeKeyframeTrajectory(out.path() / "KeyFrameTrajectory.txt");

  // TUM files keep 9 decimals of each pose value.
  const auto expectSame = [](const std::vector<FramePose>& poses, const Trajectory& file, const char* name) {
    ASSERT_EQ(file.size(), poses.size()) << name;
    for (size_t i = 0; i < poses.size(); ++i) {
      EXPECT_NEAR(file[i].timestamp, poses[i].timestamp_s, 1e-6) << name << " pose " << i;
      EXPECT_LT((file[i].T_w_c.matrix() - poses[i].T_w_c).cwiseAbs().maxCoeff(), 1e-8) << name << " pose " << i;
    }
  };
  const std::vector<FramePose> trajectory = slam.trajectory();
  ASSERT_GE(trajectory.size(), static_cast<size_t>(0.9 * kFrames));
  expectSame(trajectory, io::readTumTrajectory(out.path() / "CameraTrajectory.txt"), "CameraTrajectory.txt");
  expectSame(slam.keyframeTrajectory(), io::readTumTrajectory(out.path() / "KeyFrameTrajectory.txt"),
             "KeyFrameTrajectory.txt");
  const std::vector<FramePose> all = slam.trajectoryAll();
  expectSame(all, io::readTumTrajectory(out.path() / "CameraTrajectory_all.txt"), "CameraTrajectory_all.txt");
  // Its two last columns: the map each frame was tracked in and the map whose world its pose is in.
  std::ifstream in(out.path() / "CameraTrajectory_all.txt");
  size_t k = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double value = 0;
    for (int column = 0; column < 8; ++column) fields >> value;
    int map_id = -1, world_map_id = -1;
    fields >> map_id >> world_map_id;
    ASSERT_LT(k, all.size());
    EXPECT_EQ(map_id, all[k].map_id) << line;
    EXPECT_EQ(world_map_id, all[k].world_map_id) << line;
    ++k;
  }
  EXPECT_EQ(k, all.size());
}

TEST_F(ApiRunControlTest, DebugImagesAreWrittenPerFrame) {
  const test::TempDir out;
  const io::TumSequence frames = sequence();
  {
    RunMode mode;
    mode.deterministic = true;
    mode.debug_images_dir = out.path() / "debug";
    Slam slam(syntheticConfig(), mode);
    trackAll(slam, frames);
  }
  for (size_t i = 0; i < frames.size(); ++i) {
    const std::filesystem::path image = out.path() / "debug" / frames.record(i).rgb_path.filename();
    EXPECT_TRUE(std::filesystem::is_regular_file(image)) << image;
  }
}

// Frame k uses the mask of frame k - latency (period 1): every frame after the first few has a
// mask `latency` frames old, where without the emulation every mask is the frame's own.
TEST(ApiRunControl, EmulatedMaskLatencyHandsFramesOlderMasks) {
  test::TempDir dir;
  const CameraOptions camera = sim::syntheticCamera();
  sim::writeSequence(dir.path(), sim::SyntheticScene(sim::SceneOptions{}, camera), sim::sweepPath(kFrames, camera.fps),
                     camera, /*write_masks=*/true);
  const io::TumSequence sequence = io::TumSequence::open(dir.path());
  Config config = syntheticConfig();
  config.set("semantic.segmenter=mask_dir").set("semantic.mask_dir", (dir.path() / "masks").string());
  config.set("dynamic.mode=semantic");
  constexpr int kLatency = 4;
  const auto maskAges = [&](int latency) {
    RunMode mode;
    mode.deterministic = true;
    mode.mask_latency_frames = latency;
    Slam slam(config, mode);
    trackAll(slam, sequence);
    slam.finish();
    const nlohmann::json statistics = nlohmann::json::parse(slam.statisticsJson());
    std::vector<int> ages;
    for (const nlohmann::json& frame : statistics["per_frame"]) ages.push_back(frame["mask_age"].get<int>());
    return ages;
  };
  const std::vector<int> own = maskAges(0);
  const std::vector<int> late = maskAges(kLatency);
  ASSERT_EQ(own.size(), sequence.size());
  ASSERT_EQ(late.size(), sequence.size());
  size_t fresh = 0, as_late_as_asked = 0;
  for (size_t k = kLatency; k < sequence.size(); ++k) {
    fresh += own[k] == 0;
    as_late_as_asked += late[k] == kLatency;
  }
  const size_t frames_after = sequence.size() - kLatency;
  EXPECT_EQ(fresh, frames_after);
  EXPECT_GE(as_late_as_asked, frames_after * 9 / 10);

  RunMode bad;
  bad.mask_latency_frames = -1;
  EXPECT_THROW(Slam(config, bad), std::runtime_error);
  bad.mask_latency_frames = 2;
  bad.mask_period_frames = 0;
  EXPECT_THROW(Slam(config, bad), std::runtime_error);
  bad.mask_period_frames = 1;
  bad.realtime = true;
  EXPECT_THROW(Slam(config, bad), std::runtime_error) << "real time has its own latency";
}

}  // namespace
}  // namespace desslam
