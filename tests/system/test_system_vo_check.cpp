// tracking.vo_check_min_map_inliers on the synthetic room: a person-sized box walks through the
// view of a creeping camera, and its masks come 6 frames late (emulated real time,
// deterministic), so features on its leading edge lie outside the carried mask. The visual-odometry
// points there (the previous frame's depth at those features) move with the box; checked against
// the pose of the map points alone they are dropped, unchecked they pull the camera along (Bonn
// crowd, frames 550-650, in real time).
#include <utility>
#include <cstdio>
#include <filesystem>
#include <vector>

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

constexpr int kFrames = 150;

struct VoRun {
  double ate_m = 0;
  double worst_m = 0;  // largest camera-centre error after alignment
  size_t tracked = 0;
};

VoRun run(const std::filesystem::path& dir, int vo_check_min_map_inliers) {
  const io::TumSequence sequence = io::TumSequence::open(dir);
  SystemOptions options = test::syntheticSystemOptions();
  // Masks that miss the walker: stage 1 has nothing to check but the free-space test, stage 2 the
  // map points.
  options.semantic.segmenter = SegmenterKind::kMaskDir;
  options.semantic.mask_dir = (dir / "masks").string();
  options.dynamic.mode = DynamicMode::kFull;
  options.tracking.vo_check_min_map_inliers = vo_check_min_map_inliers;
  system::RunSettings settings;
  settings.deterministic = true;
  settings.mask_latency_frames = 6;  // real time's late masks, reproducibly
  settings.mask_period_frames = 3;
  system::SlamSystem slam(options, settings);
  for (size_t i = 0; i < sequence.size(); ++i) {
    const io::RgbdImage image = sequence.load(i, options.camera);
    slam.processFrame(image.timestamp, image.bgr, image.depth, sequence.record(i).rgb_path.filename().string());
  }
  slam.finish();
  const Trajectory camera = slam.cameraTrajectory();
  VoRun r;
  r.tracked = camera.size();
  const eval::AteResult ate = eval::computeAte(*sequence.groundTruth(), camera);
  r.ate_m = ate.translation_m.rmse;
  r.worst_m = ate.translation_m.max;
  return r;
}

TEST(SystemVoCheck, AWalkerTheLateMasksMissDoesNotCarryACreepingCamera) {
  // Two walks (speed, scene seed): masks come 6 frames late, every third frame's.
  for (const auto& [speed_m_s, seed] : std::vector<std::pair<double, unsigned>>{{1.0, 7u}, {0.7, 3u}}) {
    SCOPED_TRACE("walker " + std::to_string(speed_m_s) + " m/s, seed " + std::to_string(seed));
    test::TempDir dir;
    const CameraOptions camera = sim::syntheticCamera();
    sim::SceneOptions scene_options;
    scene_options.moving_object = true;
    scene_options.moving_velocity = Vec3(speed_m_s, 0.0, 0.0);
    scene_options.seed = seed;
    const sim::SyntheticScene scene(scene_options, camera);
    // The sweep slowed down 10 times: the camera creeps (a few cm/s) while the box walks past.
    sim::writeSequence(dir.path(), scene, sim::sweepPath(kFrames, camera.fps * 10), camera, /*write_masks=*/true);

    const VoRun checked = run(dir.path(), 20);
    const VoRun unchecked = run(dir.path(), 0);
    std::printf("walker %.1f m/s, seed %u: ATE with the VO check %.2f mm (worst %.2f mm, %zu tracked), without "
                "%.2f mm (worst %.2f mm, %zu tracked)\n",
                speed_m_s, seed, 1000 * checked.ate_m, 1000 * checked.worst_m, checked.tracked, 1000 * unchecked.ate_m,
                1000 * unchecked.worst_m, unchecked.tracked);
    EXPECT_GE(checked.tracked, static_cast<size_t>(0.95 * kFrames));
    EXPECT_LE(checked.ate_m, unchecked.ate_m);
    EXPECT_LT(checked.worst_m, unchecked.worst_m);
  }
}

}  // namespace
}  // namespace desslam
