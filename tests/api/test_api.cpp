// desslam::Slam and desslam::Config (the public API) on the synthetic room: the same trajectory
// as the internal pipeline in deterministic mode, per-frame poses, 16-bit depth, and clear errors.
#include <algorithm>

#include <opencv2/imgcodecs.hpp>

#include <gtest/gtest.h>

#include "desslam/desslam.hpp"
#include "eval/evaluation.hpp"
#include "io/tum_dataset.hpp"
#include "support/expect_contains.hpp"
#include "api_support.hpp"
#include "support/temp_dir.hpp"
#include "system/system_support.hpp"

namespace desslam {
namespace {

constexpr int kFrames = 60;

using test::syntheticConfig;

struct ApiRun {
  std::vector<FramePose> trajectory;
  std::vector<TrackResult> results;
  std::vector<FramePose> keyframes;
};

// Tracks the sequence through the public API; depth as metres or as the raw 16-bit PNG.
ApiRun trackThroughApi(const io::TumSequence& sequence, bool raw_depth) {
  const Config config = syntheticConfig();
  Slam slam(config, {.deterministic = true});
  ApiRun run;
  for (size_t i = 0; i < sequence.size(); ++i) {
    const io::RgbdImage image = sequence.load(i, config.options().camera);
    const cv::Mat depth = raw_depth ? cv::imread(sequence.record(i).depth_path.string(), cv::IMREAD_UNCHANGED)
                                    : image.depth;
    run.results.push_back(slam.track(image.timestamp, image.bgr, depth, 0,
                                     sequence.record(i).rgb_path.filename().string()));
  }
  slam.finish();
  run.trajectory = slam.trajectory();
  run.keyframes = slam.keyframeTrajectory();
  EXPECT_EQ(slam.framesProcessed(), sequence.size());
  return run;
}

class ApiTest : public test::SyntheticSequenceTest<kFrames> {};

TEST_F(ApiTest, SameTrajectoryAsThePipelineInDeterministicMode) {
  const io::TumSequence sequence = ApiTest::sequence();
  const test::RunResult reference = test::runOver(sequence, syntheticConfig().options());
  const ApiRun api = trackThroughApi(sequence, /*raw_depth=*/false);

  ASSERT_GE(reference.camera.size(), static_cast<size_t>(0.95 * kFrames));
  ASSERT_EQ(api.trajectory.size(), reference.camera.size());
  for (size_t i = 0; i < api.trajectory.size(); ++i) {
    EXPECT_EQ(api.trajectory[i].timestamp_s, reference.camera[i].timestamp);
    EXPECT_LT((api.trajectory[i].T_w_c - reference.camera[i].T_w_c.matrix()).cwiseAbs().maxCoeff(), 1e-12)
        << "frame " << i;
  }
  EXPECT_EQ(api.keyframes.size(), reference.keyframes.size());
}

TEST_F(ApiTest, EveryTrackedFrameGetsItsPoseAtOnce) {
  const io::TumSequence sequence = ApiTest::sequence();
  const ApiRun api = trackThroughApi(sequence, /*raw_depth=*/false);
  ASSERT_EQ(api.results.size(), sequence.size());
  EXPECT_TRUE(api.results.front().new_map) << "the first frame of the static room starts the map";
  EXPECT_TRUE(api.results.front().keyframe);
  size_t tracked = 0;
  Trajectory live;  // the poses track() returned, before the final bundle adjustment
  for (size_t i = 0; i < api.results.size(); ++i) {
    const TrackResult& r = api.results[i];
    if (r.state != TrackingState::kTracking) continue;
    ++tracked;
    EXPECT_EQ(r.map_id, 0);
    if (!r.new_map) {  // a map's first frame has nothing to match
      EXPECT_GT(r.inliers, 0) << "frame " << i;
    }
    live.push_back({sequence.record(i).rgb_timestamp, SE3::fromMatrix(r.T_w_c)});
  }
  EXPECT_GE(tracked, static_cast<size_t>(0.95 * kFrames));
  // The live poses are close to the truth (they are what a robot would act on).
  const eval::AteResult ate = eval::computeAte(*sequence.groundTruth(), live);
  EXPECT_LT(ate.translation_m.rmse, 0.01) << "live ATE " << ate.translation_m.rmse << " m";
}

TEST_F(ApiTest, RawSixteenBitDepthIsScaledByTheDepthFactor) {
  const io::TumSequence sequence = ApiTest::sequence();
  const ApiRun metres = trackThroughApi(sequence, /*raw_depth=*/false);
  const ApiRun raw = trackThroughApi(sequence, /*raw_depth=*/true);
  ASSERT_EQ(raw.trajectory.size(), metres.trajectory.size());
  for (size_t i = 0; i < raw.trajectory.size(); ++i)
    EXPECT_LT((raw.trajectory[i].T_w_c - metres.trajectory[i].T_w_c).cwiseAbs().maxCoeff(), 1e-9) << "frame " << i;
}

// The caller may overwrite its images once track() returns (a driver's buffer, a numpy array that
// Python frees): the pipeline keeps earlier frames' depth images (the free-space check reads the
// reference keyframe's), and must not see them change. Full dynamic mode with the sim's masks (the
// room is static: empty masks) so that the free-space check runs; each frame goes through one
// reused buffer per image, wiped after track().
TEST(Api, CallerMayReuseItsImageBuffers) {
  test::TempDir dir;
  const CameraOptions camera = sim::syntheticCamera();
  sim::writeSequence(dir.path(), sim::SyntheticScene(sim::SceneOptions{}, camera), sim::sweepPath(kFrames, camera.fps),
                     camera, /*write_masks=*/true);
  const io::TumSequence sequence = io::TumSequence::open(dir.path());
  Config config = syntheticConfig();
  config.set("semantic.segmenter=mask_dir").set("semantic.mask_dir", (dir.path() / "masks").string());
  config.set("dynamic.mode=full");
  const auto run = [&](bool reuse, bool raw_depth) {
    Slam slam(config, {.deterministic = true});
    cv::Mat bgr, depth;  // with `reuse`: the same memory every frame
    for (size_t i = 0; i < sequence.size(); ++i) {
      const io::RgbdImage image = sequence.load(i, config.options().camera);
      const cv::Mat raw = cv::imread(sequence.record(i).depth_path.string(), cv::IMREAD_UNCHANGED);
      if (!reuse) {  // fresh buffers
        bgr.release();
        depth.release();
      }
      image.bgr.copyTo(bgr);
      (raw_depth ? raw : image.depth).copyTo(depth);
      slam.track(image.timestamp, bgr, depth, 0, sequence.record(i).rgb_path.filename().string());
      if (reuse) {  // the caller writes over its buffers
        bgr.setTo(cv::Scalar::all(0));
        depth.setTo(cv::Scalar::all(0));
      }
    }
    slam.finish();
    return slam.trajectory();
  };
  const std::vector<FramePose> fresh = run(/*reuse=*/false, /*raw_depth=*/false);
  ASSERT_GE(fresh.size(), static_cast<size_t>(0.95 * kFrames));
  for (const bool raw_depth : {false, true}) {
    const std::vector<FramePose> reused = run(/*reuse=*/true, raw_depth);
    ASSERT_EQ(reused.size(), fresh.size()) << (raw_depth ? "16-bit depth" : "metres");
    double worst = 0;
    for (size_t i = 0; i < reused.size(); ++i)
      worst = std::max(worst, (reused[i].T_w_c - fresh[i].T_w_c).cwiseAbs().maxCoeff());
    EXPECT_LT(worst, 1e-9) << (raw_depth ? "16-bit depth" : "metres") << ": reused buffers changed the trajectory";
  }
}

TEST(Api, ImagesOfTheWrongTypeOrSizeAreRejectedWithTheReason) {
  Slam slam(syntheticConfig(), {.deterministic = true});
  const CameraOptions& camera = slam.config().options().camera;
  const cv::Mat bgr(camera.height, camera.width, CV_8UC3, cv::Scalar(128, 128, 128));
  const cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(1.0));
  try {
    slam.track(0.0, cv::Mat(camera.height, camera.width, CV_8UC1), depth);
    FAIL() << "a grey image was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "CV_8UC3");
  }
  try {
    slam.track(0.0, bgr, cv::Mat(camera.height / 2, camera.width, CV_32FC1));
    FAIL() << "a half-size depth image was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "camera.width/height");
  }
  try {
    slam.track(0.0, bgr, cv::Mat(camera.height, camera.width, CV_64FC1));
    FAIL() << "a double depth image was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "CV_16UC1");
  }
  // A uniform grey frame has nothing to track: no pose, no map yet.
  const TrackResult r = slam.track(0.0, bgr, depth);
  EXPECT_EQ(r.state, TrackingState::kNotInitialised);
  EXPECT_FALSE(r.hasPose());
  EXPECT_EQ(r.map_id, -1);
}

TEST(Api, ConfigAssignmentsAreCheckedAndValidated) {
  Config config = syntheticConfig();
  config.set("dense.enabled=true").set("tracking.max_depth", "6.5");
  EXPECT_TRUE(config.options().dense.enabled);
  EXPECT_DOUBLE_EQ(config.options().tracking.max_depth, 6.5);
  EXPECT_CONTAINS(config.toJson(), "\"max_depth\": 6.5");
  try {
    config.set("tracking.max_depht=3");
    FAIL() << "an unknown key was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "max_depth");  // "did you mean"
  }
  config.set("camera.fx=-1");
  EXPECT_THROW(config.validate(), std::runtime_error);
  EXPECT_THROW(Slam(config, {}), std::runtime_error);
  EXPECT_THROW(Slam(syntheticConfig(), {.deterministic = true, .realtime = true}), std::runtime_error);
  EXPECT_THROW(Config::fromYaml("/nonexistent/config.yaml"), std::runtime_error);
  EXPECT_FALSE(version().empty());
}

TEST(Api, CameraPresetsAndTheDataFolderAreFoundByName) {
  const std::filesystem::path data = dataDirectory();
  EXPECT_TRUE(std::filesystem::is_directory(data / "config")) << data;
  const Config fr1 = Config::fromPreset("tum_fr1");
  EXPECT_EQ(fr1.options().camera.width, 640);
  EXPECT_GT(fr1.options().camera.fx, 500.0);
  try {
    Config::fromPreset("tum_fr9");
    FAIL() << "an unknown preset was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "tum_fr9");
    EXPECT_CONTAINS(e.what(), (data / "config" / "tum_fr9.yaml").string());  // a place looked at
    EXPECT_CONTAINS(e.what(), "tum_fr1, tum_fr2");                             // the presets there
  }
  EXPECT_THROW(Config::fromPreset("config/tum_fr1.yaml"), std::runtime_error);  // a path, not a name
}

}  // namespace
}  // namespace desslam
