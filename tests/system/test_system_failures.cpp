// A worker thread that throws (here: a fault injected after local mapping through
// RunSettings::after_local_mapping) reaches processFrame's or finish()'s caller as a WorkerError
// instead of ending the program with std::terminate; what was built until then stays readable.
#include <atomic>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"
#include "system/slam_system.hpp"
#include "system_support.hpp"

namespace desslam {
namespace {

constexpr int kFrames = 40;

TEST(SystemFailures, LocalMappingThreadExceptionReachesTheCaller) {
  const SystemOptions options = test::syntheticSystemOptions();
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = sim::sweepPath(kFrames, options.camera.fps);
  system::RunSettings settings;  // offline: the local-mapping thread
  std::atomic<int> mapped{0};
  settings.after_local_mapping = [&mapped](uint64_t) {
    if (++mapped == 1) throw std::runtime_error("injected mapping fault");
  };
  system::SlamSystem slam(options, settings);
  std::string message;
  int frames_before_error = 0;
  for (int i = 0; i < kFrames && message.empty(); ++i) {
    const sim::RenderedFrame image = scene.render(path[i].T_w_c, path[i].timestamp);
    try {
      slam.processFrame(path[i].timestamp, image.bgr, image.depth, "frame" + std::to_string(i));
      ++frames_before_error;
    } catch (const WorkerError& e) {
      message = e.what();
      EXPECT_THROW(std::rethrow_exception(e.cause()), std::runtime_error);
    }
  }
  if (message.empty()) {  // the fault came after the last frame: finish() reports it
    try {
      slam.finish();
    } catch (const WorkerError& e) {
      message = e.what();
    }
  }
  ASSERT_GT(mapped.load(), 0) << "no keyframe reached local mapping";
  EXPECT_NE(message.find("local-mapping thread"), std::string::npos) << message;
  EXPECT_NE(message.find("injected mapping fault"), std::string::npos) << message;
  // Reported once; finish() still stops every thread, and what was tracked stays readable.
  EXPECT_NO_THROW(slam.finish());
  EXPECT_GE(slam.cameraTrajectory().size(), 1u);
  // processFrame reports the failure before a frame (not counted) or after one (counted).
  EXPECT_LE(slam.framesProcessed(), static_cast<size_t>(frames_before_error + 1));
  EXPECT_LE(slam.cameraTrajectory().size(), slam.framesProcessed());
  nlohmann::json stats;
  EXPECT_NO_THROW(stats = slam.statistics());
  EXPECT_EQ(stats["counts"]["frames"].get<size_t>(), slam.framesProcessed());
}

TEST(SystemFailures, DeterministicMappingExceptionComesOutOfProcessFrame) {
  const SystemOptions options = test::syntheticSystemOptions();
  const sim::SyntheticScene scene(sim::SceneOptions{}, options.camera);
  const Trajectory path = sim::sweepPath(kFrames, options.camera.fps);
  system::RunSettings settings;
  settings.deterministic = true;  // mapping inline: the exception is the caller's own
  settings.after_local_mapping = [](uint64_t) { throw std::runtime_error("injected mapping fault"); };
  system::SlamSystem slam(options, settings);
  bool thrown = false;
  for (int i = 0; i < kFrames && !thrown; ++i) {
    const sim::RenderedFrame image = scene.render(path[i].T_w_c, path[i].timestamp);
    try {
      slam.processFrame(path[i].timestamp, image.bgr, image.depth, "frame" + std::to_string(i));
    } catch (const std::runtime_error& e) {
      thrown = true;
      EXPECT_STREQ(e.what(), "injected mapping fault");
    }
  }
  EXPECT_TRUE(thrown);
  EXPECT_NO_THROW(slam.finish());
}

}  // namespace
}  // namespace desslam
