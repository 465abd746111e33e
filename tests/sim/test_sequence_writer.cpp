#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "sim/synthetic_scene.hpp"

namespace desslam::sim {
namespace {

namespace fs = std::filesystem;

struct ListEntry {
  std::string stamp_text;
  double timestamp;
  std::string file;
};

std::vector<ListEntry> readList(const fs::path& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::vector<ListEntry> entries;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    ListEntry e;
    fields >> e.stamp_text >> e.file;
    e.timestamp = std::stod(e.stamp_text);
    entries.push_back(e);
  }
  return entries;
}

class WriteSequence : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("desslam_sim_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(WriteSequence, WritesTumLayoutThatReadsBack) {
  SceneOptions options;
  options.moving_object = true;
  const CameraOptions camera = syntheticCamera();
  const SyntheticScene scene(options, camera);
  const Trajectory path = sweepPath(5, 30.0);
  writeSequence(dir_, scene, path, camera, true);

  const auto rgb = readList(dir_ / "rgb.txt");
  const auto depth = readList(dir_ / "depth.txt");
  const auto truth = readList(dir_ / "groundtruth.txt");
  ASSERT_EQ(rgb.size(), path.size());
  ASSERT_EQ(depth.size(), path.size());
  ASSERT_EQ(truth.size(), path.size());
  for (std::size_t i = 0; i < path.size(); ++i) {
    SCOPED_TRACE(i);
    // Six decimals, as the datasets write them.
    EXPECT_EQ(rgb[i].stamp_text.size() - rgb[i].stamp_text.find('.'), 7u);
    EXPECT_NEAR(rgb[i].timestamp, path[i].timestamp, 1e-6);
    EXPECT_NEAR(truth[i].timestamp, path[i].timestamp, 1e-6);
    EXPECT_NEAR(depth[i].timestamp - rgb[i].timestamp, kDepthTimeOffset, 1e-6);
    EXPECT_EQ(rgb[i].file, "rgb/" + rgb[i].stamp_text + ".png");
    EXPECT_EQ(depth[i].file, "depth/" + depth[i].stamp_text + ".png");

    const RenderedFrame expected = scene.render(path[i].T_w_c, path[i].timestamp);
    const cv::Mat bgr = cv::imread((dir_ / rgb[i].file).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(bgr.type(), CV_8UC3);
    EXPECT_EQ(cv::norm(bgr, expected.bgr, cv::NORM_INF), 0.0);

    const cv::Mat raw = cv::imread((dir_ / depth[i].file).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(raw.type(), CV_16UC1);
    cv::Mat metres;
    raw.convertTo(metres, CV_32F, 1.0 / camera.depth_factor);
    EXPECT_LE(cv::norm(metres, expected.depth, cv::NORM_INF), 0.5 / camera.depth_factor + 1e-6);

    const cv::Mat mask = cv::imread((dir_ / "masks" / fs::path(rgb[i].file).filename()).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(mask.type(), CV_8UC1);
    EXPECT_EQ(cv::norm(mask, expected.dynamic_mask, cv::NORM_INF), 0.0);
    EXPECT_GT(cv::countNonZero(mask), 0);
  }
  // Ground-truth poses read back (TUM order: t tx ty tz qx qy qz qw).
  std::ifstream in(dir_ / "groundtruth.txt");
  std::string line;
  std::size_t row = 0;
  while (std::getline(in, line)) {
    if (line[0] == '#') continue;
    std::istringstream fields(line);
    double t, tx, ty, tz, qx, qy, qz, qw;
    ASSERT_TRUE(fields >> t >> tx >> ty >> tz >> qx >> qy >> qz >> qw);
    const SE3 pose(Quat(qw, qx, qy, qz), Vec3(tx, ty, tz));
    EXPECT_LT((pose.translation() - path[row].T_w_c.translation()).norm(), 1e-8);
    EXPECT_LT((pose.inverse() * path[row].T_w_c).rotationAngle(), 1e-8);
    ++row;
  }
  EXPECT_EQ(row, path.size());
}

TEST_F(WriteSequence, MasksOnlyWhenAsked) {
  const CameraOptions camera = syntheticCamera();
  const SyntheticScene scene(SceneOptions{}, camera);
  writeSequence(dir_, scene, sweepPath(2, 30.0), camera, false);
  EXPECT_FALSE(fs::exists(dir_ / "masks"));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "rgb"), fs::directory_iterator{}), 2);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "depth"), fs::directory_iterator{}), 2);
}

TEST_F(WriteSequence, RejectsAMismatchedCamera) {
  const SyntheticScene scene(SceneOptions{}, syntheticCamera());
  CameraOptions other = syntheticCamera();
  other.width = 320;
  EXPECT_THROW(writeSequence(dir_, scene, sweepPath(1, 30.0), other, false), InputError);
}

}  // namespace
}  // namespace desslam::sim
