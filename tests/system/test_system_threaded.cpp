// The pipeline with its threads (offline mode, not deterministic): local mapping in its thread,
// the loop-closing thread with its mapping pause and global-BA thread, the relocaliser's keyframe
// database shared between them. Two laps of sim::loopPath, rendered in memory. Mostly here so
// the ThreadSanitizer build runs the real thread set-up; the checks are loose because thread
// timing changes keyframe decisions from run to run.
#include <cstdio>

#include <gtest/gtest.h>

#include "eval/metrics.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"
#include "system/slam_system.hpp"
#include "system_support.hpp"

namespace desslam {
namespace {

TEST(SystemThreaded, TwoLapsWithMappingAndLoopThreadsAreTracked) {
  constexpr int kFrames = 180;  // two laps of 3 s
  SystemOptions options = test::syntheticSystemOptions();
  ASSERT_TRUE(options.loop.enabled);
  ASSERT_TRUE(options.relocalisation.enabled);
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = sim::loopPath(kFrames, options.camera.fps, 2);

  system::RunSettings settings;  // offline: threads, every frame processed
  system::SlamSystem slam(options, settings);
  for (int i = 0; i < kFrames; ++i) {
    const sim::RenderedFrame image = scene.render(path[i].T_w_c, path[i].timestamp);
    slam.processFrame(path[i].timestamp, image.bgr, image.depth, "frame" + std::to_string(i));
  }
  slam.finish();
  const Trajectory camera = slam.cameraTrajectory();
  const nlohmann::json stats = slam.statistics();
  const eval::AteResult ate = eval::computeAte(path, camera);
  std::printf("threaded two laps: %zu of %d tracked, ATE RMSE %.2f mm, loop closing: %s\n", camera.size(), kFrames,
              1000 * ate.translation_m.rmse, stats["loop_closing"].dump().c_str());

  EXPECT_EQ(stats["mode"], "offline");
  EXPECT_GE(camera.size(), static_cast<size_t>(0.99 * kFrames));
  EXPECT_LT(ate.translation_m.rmse, 0.01);
  // Local mapping handed keyframes on to the loop-closing thread, and it looked at them.
  EXPECT_GT(stats["loop_closing"]["keyframes_checked"].get<size_t>(), 0u);
}

}  // namespace
}  // namespace desslam
