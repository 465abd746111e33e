#include "io/tum_dataset.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "io/config.hpp"
#include "io/trajectory_io.hpp"
#include "support/temp_dir.hpp"
#include "support/shared_data.hpp"

namespace desslam::io {
namespace {

using test::TempDir;
namespace fs = std::filesystem;

template <class Error, class F> std::string errorOf(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an exception";
  return {};
}

std::string stamp(double t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6f", t);
  return buf;
}

// Small images keep the tests fast; the reader only compares sizes with the camera.
constexpr int kWidth = 32, kHeight = 24;

CameraOptions smallCamera() {
  CameraOptions c;
  c.fx = c.fy = 30;
  c.cx = kWidth / 2.0;
  c.cy = kHeight / 2.0;
  c.width = kWidth;
  c.height = kHeight;
  return c;
}

// Writes a TUM-layout sequence: one RGB and one depth PNG per timestamp plus the two lists.
void writeSequence(const TempDir& dir, const std::vector<double>& rgb_times, const std::vector<double>& depth_times,
                   uint16_t depth_raw = 5000) {
  fs::create_directories(dir.path() / "rgb");
  fs::create_directories(dir.path() / "depth");
  std::string rgb_list = "# rgb\n# timestamp filename\n", depth_list = "# depth\n";
  for (double t : rgb_times) {
    const std::string name = "rgb/" + stamp(t) + ".png";
    cv::imwrite((dir.path() / name).string(), cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar(10, 20, 30)));
    rgb_list += stamp(t) + " " + name + "\n";
  }
  for (double t : depth_times) {
    const std::string name = "depth/" + stamp(t) + ".png";
    cv::imwrite((dir.path() / name).string(), cv::Mat(kHeight, kWidth, CV_16UC1, cv::Scalar(depth_raw)));
    depth_list += stamp(t) + " " + name + "\n";
  }
  dir.write("rgb.txt", rgb_list);
  dir.write("depth.txt", depth_list);
}

TEST(TumSequence, PairsJitteredTimestampsOneToOneSortedByTime) {
  TempDir dir;
  std::vector<double> rgb, depth;
  const double jitter[] = {0.011, -0.008, 0.004, -0.012, 0.0, 0.009, -0.003};
  for (int i = 0; i < 7; ++i) {
    rgb.push_back(100.0 + i * 0.033);
    depth.push_back(100.0 + i * 0.033 + jitter[i]);
  }
  // Lists need not be in time order.
  std::reverse(depth.begin(), depth.end());
  writeSequence(dir, rgb, depth);
  const TumSequence seq = TumSequence::open(dir.path());
  ASSERT_EQ(seq.size(), 7u);
  for (size_t i = 0; i < seq.size(); ++i) {
    EXPECT_NEAR(seq.record(i).rgb_timestamp, rgb[i], 1e-6);
    EXPECT_NEAR(seq.record(i).depth_timestamp, rgb[i] + jitter[i], 1e-6) << "frame " << i;
    EXPECT_EQ(seq.record(i).rgb_path.filename().string(), stamp(rgb[i]) + ".png");
  }
  EXPECT_TRUE(seq.warnings().empty());
  EXPECT_FALSE(seq.groundTruth().has_value());
  EXPECT_EQ(seq.directory(), dir.path());
}

TEST(TumSequence, MaxDtEdgeAndGreedyNearestFirst) {
  TempDir dir;
  // rgb 10.000 pairs with depth 10.019 (inside 0.02); rgb 20.000 has depth only at 20.021 (outside).
  // rgb 30.000 and 30.010 compete for depth 30.008: the nearer (30.010, dt 0.002) wins.
  writeSequence(dir, {10.0, 20.0, 30.0, 30.010}, {10.019, 20.021, 30.008});
  const TumSequence seq = TumSequence::open(dir.path(), 0.02);
  ASSERT_EQ(seq.size(), 2u);
  EXPECT_DOUBLE_EQ(seq.record(0).rgb_timestamp, 10.0);
  EXPECT_DOUBLE_EQ(seq.record(0).depth_timestamp, 10.019);
  EXPECT_DOUBLE_EQ(seq.record(1).rgb_timestamp, 30.010);
  EXPECT_DOUBLE_EQ(seq.record(1).depth_timestamp, 30.008);

  // A wider window lets 20.000 pair with 20.021, and 30.000 still loses 30.008 to 30.010.
  const TumSequence wide = TumSequence::open(dir.path(), 0.03);
  ASSERT_EQ(wide.size(), 3u);
  EXPECT_DOUBLE_EQ(wide.record(1).depth_timestamp, 20.021);

  // Exactly max_dt apart (in decimal) still pairs.
  TempDir edge;
  writeSequence(edge, {1.00}, {1.02});
  EXPECT_EQ(TumSequence::open(edge.path(), 0.02).size(), 1u);
}

TEST(TumSequence, MissingListedFilesAreSkippedWithAWarningEach) {
  TempDir dir;
  writeSequence(dir, {1.0, 2.0, 3.0}, {1.001, 2.001, 3.001});
  fs::remove(dir.path() / "depth" / (stamp(2.001) + ".png"));
  fs::remove(dir.path() / "rgb" / (stamp(3.0) + ".png"));
  const TumSequence seq = TumSequence::open(dir.path());
  ASSERT_EQ(seq.size(), 1u);
  EXPECT_DOUBLE_EQ(seq.record(0).rgb_timestamp, 1.0);
  const auto warnings = seq.warnings();
  ASSERT_EQ(warnings.size(), 2u);
  const auto mentions = [&](const std::string& what) {
    return std::any_of(warnings.begin(), warnings.end(),
                       [&](const std::string& w) { return w.find(what) != std::string::npos; });
  };
  EXPECT_TRUE(mentions(stamp(2.001) + ".png"));
  EXPECT_TRUE(mentions(stamp(3.0) + ".png"));
}

TEST(TumSequence, TimestampTiesAreWarningsNamingTheFileAndLines) {
  TempDir dir;
  writeSequence(dir, {1.0, 2.0, 3.0}, {1.001, 2.001, 3.001});
  // rgb.txt: two header lines, then 1.0 (line 3), 2.0 (line 4), 3.0 (line 5); line 6 repeats 2.0.
  std::ofstream(dir.path() / "rgb.txt", std::ios::app) << stamp(2.0) << " rgb/" << stamp(3.0) << ".png\n";
  const TumSequence seq = TumSequence::open(dir.path());
  EXPECT_EQ(seq.size(), 3u);
  const auto warnings = seq.warnings();
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("rgb.txt"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("lines 4 and 6"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("same timestamp"), std::string::npos) << warnings[0];
}

TEST(TumSequence, BadGroundTruthIsAWarningNotAnError) {
  TempDir dir;
  writeSequence(dir, {1.0, 2.0}, {1.001, 2.001});
  dir.write("groundtruth.txt", "1.0 0 0 0 0 0 0 1\n2.0 nan 0 0 0 0 0 1\n");
  const TumSequence seq = TumSequence::open(dir.path());
  EXPECT_EQ(seq.size(), 2u);
  EXPECT_FALSE(seq.groundTruth().has_value());
  EXPECT_NE(seq.groundTruthProblem().find("groundtruth.txt:2"), std::string::npos) << seq.groundTruthProblem();
  const auto warnings = seq.warnings();
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("ignoring the ground truth"), std::string::npos) << warnings[0];
}

TEST(TrajectoryFile, NonFiniteAndHugeValuesAreErrorsNamingTheLine) {
  for (const std::string& bad : {"1 nan 0 0 0 0 0 1", "1 0 inf 0 0 0 0 1", "1 0 0 0 0 0 0 -nan", "inf 0 0 0 0 0 0 1",
                                 "1 1e300 0 0 0 0 0 1", "1 0 0 1e999 0 0 0 1", "1 0 0 x 0 0 0 1"}) {
    SCOPED_TRACE(bad);
    std::istringstream in("# header\n0 0 0 0 0 0 0 1\n" + bad + "\n");
    const std::string message = errorOf<InputError>([&] { parseTumTrajectory(in, "t.txt"); });
    EXPECT_NE(message.find("t.txt:3"), std::string::npos) << message;
  }
  std::istringstream ties("1 0 0 0 0 0 0 1\n1 0 0 1 0 0 0 1\n");
  std::vector<std::string> warnings;
  EXPECT_EQ(parseTumTrajectory(ties, "t.txt", &warnings).size(), 2u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("lines 1 and 2"), std::string::npos) << warnings[0];
}

TEST(AtlasTrajectoryFile, ReadsBackWhatTheWriterWrote) {
  TempDir dir;
  const AtlasTrajectory written = {{10.5, SE3(Quat(1, 0, 0, 0), Vec3(1, 2, 3)), 0, 0},
                                   {10.6, SE3(Quat(0, 1, 0, 0), Vec3(-1, 0.5, 2)), 3, 1}};
  writeAtlasTrajectory(dir.path() / "all.txt", written);
  EXPECT_TRUE(hasAtlasColumns(dir.path() / "all.txt"));
  const AtlasTrajectory back = readAtlasTrajectory(dir.path() / "all.txt");
  ASSERT_EQ(back.size(), 2u);
  for (size_t i = 0; i < back.size(); ++i) {
    EXPECT_DOUBLE_EQ(back[i].timestamp, written[i].timestamp);
    EXPECT_LT((back[i].T_w_c.translation() - written[i].T_w_c.translation()).norm(), 1e-9);
    EXPECT_LT((back[i].T_w_c * written[i].T_w_c.inverse()).rotationAngle(), 1e-9);
    EXPECT_EQ(back[i].map, written[i].map);
    EXPECT_EQ(back[i].world_map, written[i].world_map);
  }
  writeTumTrajectory(dir.path() / "tum.txt", {{10.5, SE3()}});
  EXPECT_FALSE(hasAtlasColumns(dir.path() / "tum.txt"));
  EXPECT_FALSE(hasAtlasColumns(dir.path() / "missing.txt"));
}

TEST(AtlasTrajectoryFile, MalformedLinesAreErrorsNamingTheLine) {
  for (const auto& [bad, expected] : std::vector<std::pair<std::string, std::string>>{
           {"1 0 0 0 0 0 0 1", "expected 10 columns"},
           {"1 0 0 0 0 0 0 1 0 0 7", "expected 10 columns"},
           {"1 0 0 0 0 0 0 1 x 0", "map 'x' is not a map id"},
           {"1 0 0 0 0 0 0 1 0 -2", "world_map '-2' is not a map id"},
           {"1 0 nan 0 0 0 0 1 0 0", "not a finite number"}}) {
    SCOPED_TRACE(bad);
    std::istringstream in("# header\n\n0 0 0 0 0 0 0 1 0 0\n" + bad + "\n");
    const std::string message = errorOf<InputError>([&] { parseAtlasTrajectory(in, "all.txt"); });
    EXPECT_NE(message.find("all.txt:4"), std::string::npos) << message;
    EXPECT_NE(message.find(expected), std::string::npos) << message;
  }
}

TEST(TumSequence, LoadsImagesAndConvertsDepthToMetres) {
  TempDir dir;
  writeSequence(dir, {5.0}, {5.001}, 7500);
  CameraOptions camera = smallCamera();
  const TumSequence seq = TumSequence::open(dir.path());
  RgbdImage image = seq.load(0, camera);
  EXPECT_DOUBLE_EQ(image.timestamp, 5.0);
  ASSERT_EQ(image.bgr.type(), CV_8UC3);
  ASSERT_EQ(image.depth.type(), CV_32FC1);
  EXPECT_EQ(image.bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));
  EXPECT_FLOAT_EQ(image.depth.at<float>(3, 4), 1.5f);
  camera.depth_factor = 1000;
  EXPECT_FLOAT_EQ(seq.load(0, camera).depth.at<float>(3, 4), 7.5f);
}

TEST(TumSequence, ZeroDepthStaysNoReading) {
  TempDir dir;
  writeSequence(dir, {5.0}, {5.001}, 0);
  const RgbdImage image = TumSequence::open(dir.path()).load(0, smallCamera());
  EXPECT_EQ(cv::countNonZero(image.depth), 0);
}

TEST(TumSequence, OpenErrorsNameTheFolderOrFile) {
  TempDir dir;
  const fs::path missing = dir.path() / "no_such_sequence";
  EXPECT_NE(errorOf<InputError>([&] { TumSequence::open(missing); }).find("no_such_sequence"), std::string::npos);

  writeSequence(dir, {1.0}, {1.0});
  fs::remove(dir.path() / "depth.txt");
  const std::string no_list = errorOf<InputError>([&] { TumSequence::open(dir.path()); });
  EXPECT_NE(no_list.find("depth.txt"), std::string::npos) << no_list;
  EXPECT_NE(no_list.find(dir.path().string()), std::string::npos) << no_list;

  dir.write("depth.txt", "1.0 depth/" + stamp(1.0) + ".png\n");
  dir.write("rgb.txt", "# only comments\n\n");
  const std::string empty = errorOf<InputError>([&] { TumSequence::open(dir.path()); });
  EXPECT_NE(empty.find("rgb.txt"), std::string::npos) << empty;
  EXPECT_NE(empty.find("no images"), std::string::npos) << empty;

  dir.write("rgb.txt", "1.0 rgb/a.png\nnot-a-number rgb/b.png\n");
  const std::string malformed = errorOf<InputError>([&] { TumSequence::open(dir.path()); });
  EXPECT_NE(malformed.find("rgb.txt:2"), std::string::npos) << malformed;
}

TEST(TumSequence, NoPairsWithinMaxDtSaysTimestampsDoNotMatch) {
  TempDir dir;
  writeSequence(dir, {1.0, 2.0}, {1.5, 2.5});
  const std::string msg = errorOf<InputError>([&] { TumSequence::open(dir.path()); });
  EXPECT_NE(msg.find("timestamps do not match"), std::string::npos) << msg;
  EXPECT_NE(msg.find("rgb.txt"), std::string::npos) << msg;
}

TEST(TumSequence, AllListedFilesMissingIsAnError) {
  TempDir dir;
  writeSequence(dir, {1.0}, {1.0});
  fs::remove_all(dir.path() / "rgb");
  const std::string msg = errorOf<InputError>([&] { TumSequence::open(dir.path()); });
  EXPECT_NE(msg.find("rgb.txt"), std::string::npos) << msg;
}

TEST(TumSequence, LoadErrorsNameTheImageFile) {
  TempDir dir;
  writeSequence(dir, {1.0, 2.0, 3.0, 4.0, 5.0}, {1.0, 2.0, 3.0, 4.0, 5.0});
  const auto depthFile = [&](double t) { return dir.path() / "depth" / (stamp(t) + ".png"); };
  const auto rgbFile = [&](double t) { return dir.path() / "rgb" / (stamp(t) + ".png"); };
  // Frame 0: 8-bit depth. Frame 1: corrupt PNG bytes. Frame 2: grey RGB. Frame 3: wrong size.
  cv::imwrite(depthFile(1.0).string(), cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(5)));
  dir.write("depth/" + stamp(2.0) + ".png", "\x89PNG\r\n\x1a\n this is not really a PNG");
  cv::imwrite(rgbFile(3.0).string(), cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(5)));
  cv::imwrite(depthFile(4.0).string(), cv::Mat(kHeight * 2, kWidth * 2, CV_16UC1, cv::Scalar(5000)));
  const TumSequence seq = TumSequence::open(dir.path());
  ASSERT_EQ(seq.size(), 5u);
  const CameraOptions camera = smallCamera();

  const std::string eight_bit = errorOf<InputError>([&] { seq.load(0, camera); });
  EXPECT_NE(eight_bit.find("depth must be 16-bit PNG (CV_16U), got 8-bit"), std::string::npos) << eight_bit;
  EXPECT_NE(eight_bit.find(depthFile(1.0).string()), std::string::npos) << eight_bit;

  const std::string corrupt = errorOf<InputError>([&] { seq.load(1, camera); });
  EXPECT_NE(corrupt.find(depthFile(2.0).string()), std::string::npos) << corrupt;

  const std::string grey = errorOf<InputError>([&] { seq.load(2, camera); });
  EXPECT_NE(grey.find("3-channel"), std::string::npos) << grey;
  EXPECT_NE(grey.find(rgbFile(3.0).string()), std::string::npos) << grey;

  const std::string size = errorOf<InputError>([&] { seq.load(3, camera); });
  EXPECT_NE(size.find("64x48"), std::string::npos) << size;
  EXPECT_NE(size.find(depthFile(4.0).string()), std::string::npos) << size;

  EXPECT_NO_THROW(seq.load(4, camera));
  CameraOptions other = camera;
  other.width = 640;
  const std::string camera_size = errorOf<InputError>([&] { seq.load(4, other); });
  EXPECT_NE(camera_size.find(rgbFile(5.0).string()), std::string::npos) << camera_size;

  // A file removed after open() is reported by name too.
  fs::remove(rgbFile(5.0));
  EXPECT_NE(errorOf<InputError>([&] { seq.load(4, camera); }).find(rgbFile(5.0).string()), std::string::npos);
  EXPECT_THROW(seq.load(99, camera), InputError);
}

TEST(TumSequence, ReadsGroundTruthWhenPresent) {
  TempDir dir;
  writeSequence(dir, {1.0}, {1.0});
  dir.write("groundtruth.txt", "# timestamp tx ty tz qx qy qz qw\n0.99 1 2 3 0 0 0 1\n1.01 1 2 3.5 0 0 0 1\n");
  const TumSequence seq = TumSequence::open(dir.path());
  ASSERT_TRUE(seq.groundTruth().has_value());
  ASSERT_EQ(seq.groundTruth()->size(), 2u);
  EXPECT_DOUBLE_EQ(seq.groundTruth()->at(1).T_w_c.translation().z(), 3.5);
}

TEST(CheckDepthScale, RejectsImplausibleMedianAndNamesTheFile) {
  const fs::path file = "depth/123.png";
  cv::Mat depth(48, 64, CV_32FC1, cv::Scalar(1.5f));
  depth(cv::Rect(0, 0, 64, 10)).setTo(0);  // holes do not count
  EXPECT_NO_THROW(checkDepthScale(depth, file, 5000));

  // Millimetre PNG read with factor 5000... fine; metre-scale PNG read with 5000 => far too close.
  cv::Mat too_close(48, 64, CV_32FC1, cv::Scalar(0.0003f));
  const std::string close_msg = errorOf<InputError>([&] { checkDepthScale(too_close, file, 5000); });
  EXPECT_NE(close_msg.find("check camera.depth_factor"), std::string::npos) << close_msg;
  EXPECT_NE(close_msg.find("123.png"), std::string::npos) << close_msg;

  cv::Mat too_far(48, 64, CV_32FC1, cv::Scalar(60.0f));
  EXPECT_THROW(checkDepthScale(too_far, file, 100), InputError);

  // No valid reading at all: nothing to judge.
  EXPECT_NO_THROW(checkDepthScale(cv::Mat::zeros(48, 64, CV_32FC1), file, 5000));
}

// ---- the real clips in ../shared ----

struct ClipCase {
  const char* clip;
  const char* preset;
  size_t pairs;  // what TUM's associate.py (max_difference 0.02) gives for the clip
};

class RealClip : public ::testing::TestWithParam<ClipCase> {};

TEST_P(RealClip, OpensWithAllPairsAndGroundTruthAndLoadsPlausibleDepth) {
  const fs::path dir = test::clipDir(GetParam().clip);
  DESSLAM_REQUIRE_SHARED(dir);
  const TumSequence seq = TumSequence::open(dir);
  EXPECT_EQ(seq.size(), GetParam().pairs);
  EXPECT_TRUE(seq.warnings().empty());
  ASSERT_TRUE(seq.groundTruth().has_value());
  EXPECT_GT(seq.groundTruth()->size(), 100u);
  for (size_t i = 1; i < seq.size(); ++i) {
    EXPECT_GT(seq.record(i).rgb_timestamp, seq.record(i - 1).rgb_timestamp);
    EXPECT_LE(std::abs(seq.record(i).rgb_timestamp - seq.record(i).depth_timestamp), 0.02);
  }

  const SystemOptions options = loadConfig(test::sourceDir() / "config" / GetParam().preset);
  const RgbdImage image = seq.load(0, options.camera);
  EXPECT_EQ(image.bgr.cols, 640);
  EXPECT_EQ(image.bgr.rows, 480);
  EXPECT_NO_THROW(checkDepthScale(image.depth, seq.record(0).depth_path, options.camera.depth_factor));
  const double valid_share = cv::countNonZero(image.depth) / static_cast<double>(image.depth.total());
  EXPECT_GT(valid_share, 0.5);
  double min_depth = 0, max_depth = 0;
  cv::minMaxLoc(image.depth, &min_depth, &max_depth);
  EXPECT_GT(max_depth, 0.5);
  EXPECT_LT(max_depth, 12.0);  // Kinect/Xtion range, with depth_factor 5000
  EXPECT_NEAR(cv::mean(image.depth, image.depth > 0)[0], 2.0, 1.5);
}

// fr1_xyz: 100 RGB and 101 depth frames; every RGB frame has a depth frame within 0.018 s, but five
// times two RGB frames want the same depth frame and pairing is one-to-one (associate.py gives 95).
INSTANTIATE_TEST_SUITE_P(Clips, RealClip,
                         ::testing::Values(ClipCase{"fr1_xyz_0000_0099", "tum_fr1.yaml", 95},
                                           ClipCase{"bonn_crowd_0300_0399", "bonn.yaml", 100}),
                         [](const auto& info) { return std::string(info.param.clip); });

}  // namespace
}  // namespace desslam::io
