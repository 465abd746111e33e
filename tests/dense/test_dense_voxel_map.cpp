// The voxel map's promises: memory grows with the scene, not with the keyframes; pose updates
// after insertion move the exported points; keys follow large pose changes (re-keying); the
// map sidecar round trip; the map check on a run folder (what `desslam mapcheck` does).
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <open3d/geometry/PointCloud.h>
#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "dense/dense_map.hpp"
#include "dense/map_export.hpp"
#include "dense/run_map_check.hpp"
#include "dense_test_support.hpp"
#include "io/trajectory_io.hpp"
#include "support/temp_dir.hpp"

namespace desslam::dense {
namespace {

namespace fs = std::filesystem;
using test::noFilterOptions;
using test::planeKeyframe;
using test::smallCamera;

// The same static view of a wall 2 m away as n keyframes, each pose off by up to 2 mm / 0.05
// deg (what tracking noise does to a still camera). Every pixel is mapped (0.8 cm apart on the
// wall, finer than the 1 cm voxels) and the wall lies mid-voxel, so one view already fills the
// wall's voxels and later views can only merge.
size_t voxelsAfterStillKeyframes(int n) {
  const PinholeCamera camera(smallCamera(320, 240));
  DenseOptions options = noFilterOptions();
  options.pixel_stride = 1;
  DenseMap map(options, camera);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-1.0, 1.0);
  for (int i = 0; i < n; ++i) {
    const SE3 T_w_c(Mat3(Eigen::AngleAxisd(0.05 * M_PI / 180 * jitter(rng), Vec3::UnitY())),
                    Vec3(0.002 * jitter(rng), 0.002 * jitter(rng), 0.002 * jitter(rng)));
    map.addKeyframe(planeKeyframe(camera, static_cast<uint64_t>(i), i, T_w_c, Vec3::UnitZ(), 2.005));
  }
  EXPECT_EQ(map.keyframeCount(), static_cast<size_t>(n));
  return map.voxelCount();
}

TEST(DenseVoxelMap, MemoryFollowsTheSceneNotTheKeyframeCount) {
  const size_t five = voxelsAfterStillKeyframes(5);
  const size_t fifty = voxelsAfterStillKeyframes(50);
  std::cout << "voxels after 5 keyframes " << five << ", after 50 " << fifty << "\n";
  ASSERT_GT(five, 10000u);
  // Per-keyframe clouds would grow 10x; merged voxels only by the few new boundary voxels.
  EXPECT_LT(static_cast<double>(fifty) / five, 1.15);
}

// Keyframe 1 sees the wall z = 3 around x = 0, keyframe 2 the same wall around x = 6: disjoint.
class TwoDisjointViews : public ::testing::Test {
 protected:
  PinholeCamera camera{smallCamera(160, 120)};
  SE3 T_w_1 = SE3();
  SE3 T_w_2 = SE3(Mat3::Identity(), Vec3(6.0, 0, 0));
  DenseKeyframe kf1 = planeKeyframe(camera, 1, 1.0, T_w_1, Vec3::UnitZ(), 3.0);
  DenseKeyframe kf2 = planeKeyframe(camera, 2, 2.0, T_w_2, Vec3::UnitZ(), 3.0);

  static Vec3 centreOf(const DenseCloud& cloud, bool right_half) {
    Vec3 sum = Vec3::Zero();
    size_t n = 0;
    for (const Vec3& p : cloud.points_w) {
      if ((p.x() > 3.0) != right_half) continue;
      sum += p;
      ++n;
    }
    return n == 0 ? Vec3::Zero() : Vec3(sum / n);
  }
};

TEST_F(TwoDisjointViews, PoseUpdateAfterInsertionMovesOnlyThatKeyframesPoints) {
  DenseMap map(noFilterOptions(), camera);
  map.addKeyframe(kf1);
  map.addKeyframe(kf2);
  const DenseCloud before = map.exportCloud();
  // A constructed correction: keyframe 2 moves 0.3 m up and turns 2 degrees about the view axis.
  const SE3 corrected = T_w_2 * SE3(Mat3(Eigen::AngleAxisd(2 * M_PI / 180, Vec3::UnitZ())), Vec3(0, 0.3, 0));
  map.updatePoses({{2, corrected}});
  const DenseCloud after = map.exportCloud();
  ASSERT_NEAR(static_cast<double>(after.size()), static_cast<double>(before.size()), before.size() * 0.01);
  EXPECT_LT((centreOf(after, false) - centreOf(before, false)).norm(), 1e-6);  // keyframe 1 untouched
  const Vec3 expected = corrected * (T_w_2.inverse() * centreOf(before, true));
  EXPECT_LT((centreOf(after, true) - expected).norm(), 0.003) << centreOf(after, true).transpose();
  // Every point of keyframe 2 moved with it (each is within a voxel of its corrected place).
  for (const Vec3& p : after.points_w) {
    if (p.x() < 3.0) continue;
    const Vec3 p_c = corrected.inverse() * p;
    ASSERT_NEAR(p_c.z(), 3.0, 1e-3) << p.transpose();  // still on keyframe 2's wall, in its frame
  }
  // The export placed the voxels with the new poses itself: the re-key waits for the next
  // keyframe (or rekeyNow()), and does not change what is exported.
  EXPECT_EQ(map.stats().rekeys, 0u);
  map.rekeyNow();
  EXPECT_EQ(map.stats().rekeys, 1u);
  EXPECT_GT(map.stats().voxels_rekeyed, 0u);
  const DenseCloud rekeyed = map.exportCloud();
  ASSERT_EQ(rekeyed.size(), after.size());
  for (size_t i = 0; i < after.size(); ++i) ASSERT_LT((rekeyed.points_w[i] - after.points_w[i]).norm(), 1e-6);
}

TEST_F(TwoDisjointViews, KeysFollowLargePoseChangesSoNewViewsMergeNotDuplicate) {
  DenseMap map(noFilterOptions(), camera);
  map.addKeyframe(kf1);
  const size_t voxels = map.voxelCount();
  // A loop closure moves keyframe 1 by 0.25 m along the wall; a new keyframe then sees the wall
  // from the corrected pose. Stale keys would put all its points in new voxels.
  const SE3 corrected(Mat3::Identity(), Vec3(0.253, 0.117, 0));
  map.updatePoses({{1, corrected}});
  EXPECT_EQ(map.stats().rekeys, 0u);  // deferred to the next keyframe
  map.addKeyframe(planeKeyframe(camera, 3, 3.0, corrected, Vec3::UnitZ(), 3.0));
  EXPECT_EQ(map.stats().rekeys, 1u);
  EXPECT_LT(map.voxelCount(), voxels + voxels / 50);

  // Tiny updates (below half a voxel of motion) do not re-key.
  map.updatePoses({{1, corrected * SE3(Mat3::Identity(), Vec3(0.001, 0, 0))}});
  map.rekeyNow();
  EXPECT_EQ(map.stats().rekeys, 1u);
}

TEST_F(TwoDisjointViews, MinObservationsKeepsOnlyVoxelsSeenByEnoughKeyframes) {
  DenseOptions options = noFilterOptions();
  options.min_observations = 2;
  DenseMap map(options, camera);
  map.addKeyframe(kf1);
  map.addKeyframe(kf2);
  EXPECT_EQ(map.exportCloud().size(), 0u);  // disjoint: every voxel seen once
  map.addKeyframe(planeKeyframe(camera, 3, 3.0, T_w_1, Vec3::UnitZ(), 3.0));
  const DenseCloud cloud = map.exportCloud();
  EXPECT_GT(cloud.size(), 1000u);
  for (size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_LT(cloud.points_w[i].x(), 3.0);
    ASSERT_GE(cloud.observations[i], 2u);
    ASSERT_DOUBLE_EQ(cloud.first_seen[i], 1.0);  // first seen by keyframe 1, not 3
  }
}

// carve() skips anchors whose voxels cannot be in view; the misses it counts must still be
// those of checking every voxel. Reference: every stored voxel (worldScans) projected into the
// carving camera and tested with the same 3x3 rule. Keyframe 1's wall spans x in [-1.9, 1.9],
// keyframe 2's x in [4.1, 7.9]; the carving camera at x = 3 sees a wall behind (z = 5) over
// x in [1.1, 4.9], so both anchors are partly in view; turned around, or far off, it sees none.
TEST_F(TwoDisjointViews, CarveSkipsOnlyAnchorsOutOfViewAndCountsEveryMiss) {
  DenseMap map(noFilterOptions(), camera);
  map.addKeyframe(kf1);
  map.addKeyframe(kf2);
  const DenseOptions options = map.options();
  const auto expectedMisses = [&](const cv::Mat& depth, const SE3& T_w_c) {
    size_t misses = 0;
    for (const WorldScan& scan : map.worldScans())
      for (const Vec3& p_w : scan.points_w) {
        const Vec3 p_c = T_w_c.inverse() * p_w;
        if (p_c.z() < options.min_depth || p_c.z() > options.max_depth) continue;
        const Vec2 uv = camera.project(p_c);
        if (!camera.inImage(uv)) continue;
        const int x = static_cast<int>(std::lround(uv.x())), y = static_cast<int>(std::lround(uv.y()));
        if (x < 1 || y < 1 || x >= depth.cols - 1 || y >= depth.rows - 1) continue;
        bool through = depth.at<float>(y, x) > 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const float d = depth.at<float>(y + dy, x + dx);
            if (d > 0 && d <= p_c.z() + options.carve_tolerance) through = false;
          }
        misses += through ? 1 : 0;
      }
    return misses;
  };
  const SE3 between(Mat3::Identity(), Vec3(3.0, 0, 0));
  const SE3 turned(Mat3(Eigen::AngleAxisd(M_PI, Vec3::UnitY())), Vec3(3.0, 0, 0));
  const SE3 far_off(Mat3::Identity(), Vec3(20.0, 0, 0));
  const std::vector<SE3> cameras = {between, turned, far_off};
  for (size_t c = 0; c < cameras.size(); ++c) {
    const SE3& T_w_c = cameras[c];
    // The turned camera looks down -z: a wall at z = -2 behind it in its view.
    const cv::Mat depth = test::planeDepth(camera, T_w_c, Vec3::UnitZ(), c == 1 ? -2.0 : 5.0);
    const size_t expected = expectedMisses(depth, T_w_c);
    const size_t missed = map.carve(depth, T_w_c);
    // float vs double projection may round a pixel differently for a voxel or two
    EXPECT_NEAR(static_cast<double>(missed), static_cast<double>(expected), 2.0 + expected * 0.002)
        << "camera at " << T_w_c.translation().transpose();
    if (c == 0) {
      EXPECT_GT(expected, 1000u);  // both walls partly seen through
    } else {
      EXPECT_EQ(expected, 0u);
    }
  }
}

// ---- sidecar ------------------------------------------------------------------------------

TEST(MapSources, RoundTripAndClearErrors) {
  desslam::test::TempDir dir;
  const std::vector<Timestamp> times = {1305031102.175304, 1305031102.211214, 0.0, -1.5};
  writeMapSources(dir.path() / "s.bin", times);
  EXPECT_EQ(readMapSources(dir.path() / "s.bin"), times);
  EXPECT_EQ(readMapSources(dir.path() / "s.bin", times.size()), times);
  auto expectError = [](const auto& call, const std::string& part) {
    try {
      call();
      FAIL() << "expected InputError containing '" << part << "'";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  expectError([&] { readMapSources(dir.path() / "s.bin", 5); }, "belongs to another dense_map.ply");
  expectError([&] { readMapSources(dir.path() / "none.bin"); }, "none.bin is missing");
  {
    std::ofstream bad(dir.path() / "bad.bin", std::ios::binary);
    bad << "ply\nformat binary_little_endian 1.0\n";
  }
  expectError([&] { readMapSources(dir.path() / "bad.bin"); }, "not a dense-map sidecar");
  fs::resize_file(dir.path() / "s.bin", fs::file_size(dir.path() / "s.bin") - 8);
  expectError([&] { readMapSources(dir.path() / "s.bin"); }, "truncated");
  EXPECT_THROW(writeMapSources(dir.path() / "missing" / "s.bin", times), OutputError);
}

// ---- the map check on a run folder ----------------------------------------------------------

// A two-frame TUM sequence: at t = 1 a "person" (a box 1 m away) stands in front of the wall at
// 2 m; at t = 2 the person is gone. The run mapped frame 1 without a mask, so the person's
// points are ghosts that frame 2 sees through; the wall's points are not.
class RunFolderCheck : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_options = smallCamera(160, 120);
    const PinholeCamera camera(camera_options);
    fs::create_directories(sequence() / "rgb");
    fs::create_directories(sequence() / "depth");
    fs::create_directories(out());
    std::ofstream rgb_list(sequence() / "rgb.txt"), depth_list(sequence() / "depth.txt");
    std::vector<DenseKeyframe> frames;
    for (int i = 1; i <= 2; ++i) {
      DenseKeyframe kf = planeKeyframe(camera, static_cast<uint64_t>(i), i, SE3(), Vec3::UnitZ(), 2.0);
      if (i == 1) kf.depth(person).setTo(1.0);
      const std::string name = std::to_string(i) + ".png";
      cv::Mat raw;
      kf.depth.convertTo(raw, CV_16U, camera_options.depth_factor);
      cv::imwrite((sequence() / "depth" / name).string(), raw);
      cv::imwrite((sequence() / "rgb" / name).string(), kf.bgr);
      rgb_list << i << ".000000 rgb/" << name << "\n";
      depth_list << i << ".000000 depth/" << name << "\n";
      frames.push_back(kf);
    }
    io::writeTumTrajectory(out() / "KeyFrameTrajectory.txt", {{1.0, SE3()}, {2.0, SE3()}});
    DenseMap map(noFilterOptions(), camera);
    map.addKeyframe(frames[0]);
    const DenseCloud cloud = map.exportCloud();
    for (const Vec3& p : cloud.points_w) ghosts += p.z() < 1.5 ? 1 : 0;
    points = cloud.size();
    writePly(out() / "dense_map.ply", *toOpen3d(cloud));
    writeMapSources(out() / "dense_map_sources.bin", cloud.first_seen);
  }
  fs::path sequence() const { return dir.path() / "sequence"; }
  fs::path out() const { return dir.path() / "out"; }

  desslam::test::TempDir dir;
  CameraOptions camera_options;
  cv::Rect person{60, 30, 30, 60};
  size_t ghosts = 0, points = 0;
};

TEST_F(RunFolderCheck, CountsTheGhostPointsExactly) {
  ASSERT_GT(ghosts, 50u);
  const RunMapCheckResult result = checkRunMap(out(), sequence(), camera_options);
  EXPECT_EQ(result.map_points, points);
  EXPECT_EQ(result.keyframes, 2u);
  EXPECT_EQ(result.check.checked, points);  // all seen by the later frame
  EXPECT_EQ(result.check.violations, ghosts);
}

TEST_F(RunFolderCheck, MismatchedOrMissingFilesAreNamed) {
  auto expectError = [&](const std::string& part) {
    try {
      checkRunMap(out(), sequence(), camera_options);
      FAIL() << "expected InputError containing '" << part << "'";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  writeMapSources(out() / "dense_map_sources.bin", std::vector<Timestamp>(points + 1, 0.0));
  expectError("belongs to another dense_map.ply");
  fs::remove(out() / "dense_map_sources.bin");
  expectError("dense_map_sources.bin does not exist");
  writeMapSources(out() / "dense_map_sources.bin", std::vector<Timestamp>(points, 1.0));
  fs::remove(sequence() / "depth" / "2.png");  // the later keyframe's depth
  expectError("keyframe at time 2.000000");
  fs::remove(out() / "KeyFrameTrajectory.txt");
  expectError("KeyFrameTrajectory.txt does not exist");
}

// Free-space carving: what one keyframe saw at 1 m is seen THROUGH by a later keyframe at the
// same place that measures the wall at 3 m (the person walked on): left out of the export. A
// later keyframe measuring something in FRONT (0.5 m) says nothing about it and keeps it.
class Carving : public ::testing::Test {
 protected:
  PinholeCamera camera{smallCamera(160, 120)};
  static size_t pointsNear(const DenseCloud& cloud, double z) {
    size_t n = 0;
    for (const Vec3& p : cloud.points_w) n += std::abs(p.z() - z) < 0.02 ? 1 : 0;
    return n;
  }
  DenseCloud run(bool carve, double second_view_depth, size_t* misses = nullptr) {
    DenseOptions options = noFilterOptions();
    options.carve_free_space = carve;
    DenseMap map(options, camera);
    map.addKeyframe(planeKeyframe(camera, 1, 1.0, SE3(), Vec3::UnitZ(), 1.0));
    map.addKeyframe(planeKeyframe(camera, 2, 2.0, SE3(), Vec3::UnitZ(), second_view_depth));
    if (misses != nullptr) *misses = map.stats().voxel_misses;
    return map.extract();
  }
};

TEST_F(Carving, AGhostSeenThroughLaterIsLeftOut) {
  size_t misses = 0;
  const DenseCloud carved = run(true, 3.0, &misses);
  EXPECT_GT(misses, 1000u);
  EXPECT_GT(pointsNear(carved, 3.0), 1000u);
  const DenseCloud kept = run(false, 3.0);
  EXPECT_GT(pointsNear(kept, 1.0), 1000u);  // the same scene without carving keeps the ghost
  // Only the image's outermost pixels escape (the see-through test needs the 3x3 window).
  EXPECT_LT(pointsNear(carved, 1.0), pointsNear(kept, 1.0) / 20);
}

TEST_F(Carving, SomethingInFrontOrTheSameSurfaceCarvesNothing) {
  size_t misses = 0;
  const DenseCloud occluded = run(true, 0.5, &misses);
  EXPECT_EQ(misses, 0u);
  EXPECT_GT(pointsNear(occluded, 1.0), 1000u);
  const DenseCloud same = run(true, 1.0, &misses);
  EXPECT_EQ(misses, 0u);
  EXPECT_GT(pointsNear(same, 1.0), 1000u);
}

}  // namespace
}  // namespace desslam::dense
