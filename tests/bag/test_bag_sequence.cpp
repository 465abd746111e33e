// ROS 1 bags as input (bag/bag_sequence.hpp): bags written here with the rosbag storage library
// (bz2 chunks, as TUM's) from the shared fr1_xyz clip and from synthetic scenes read back as the
// same frames, give the folder's deterministic trajectory, and bad bags are clear errors.
#include "bag/bag_sequence.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "bag/bag_writer.hpp"
#include "bag/open_sequence.hpp"
#include "core/error.hpp"
#include "eval/evaluation.hpp"
#include "io/config.hpp"
#include "io/tum_dataset.hpp"
#include "sim/synthetic_scene.hpp"
#include "support/expect_contains.hpp"
#include "support/shared_data.hpp"
#include "support/temp_dir.hpp"
#include "system/system_support.hpp"

namespace desslam::bag {
namespace {

namespace fs = std::filesystem;

template <class F>
std::string inputErrorOf(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an InputError";
  return {};
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int r = 0; r < a.rows; ++r)
    if (std::memcmp(a.ptr(r), b.ptr(r), a.cols * a.elemSize()) != 0) return false;
  return true;
}

// Same timestamps, and poses equal to 1e-9 (m, and rotation-matrix entries).
void expectSameTrajectory(const Trajectory& a, const Trajectory& b) {
  ASSERT_EQ(a.size(), b.size());
  double worst = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].timestamp, b[k].timestamp) << "pose " << k;
    const Mat4 difference = a[k].T_w_c.matrix() - b[k].T_w_c.matrix();
    worst = std::max(worst, difference.cwiseAbs().maxCoeff());
  }
  EXPECT_LE(worst, 1e-9) << "largest pose difference";
}

// The synthetic static room (src/sim) as a TUM folder with ground truth.
fs::path writeSyntheticFolder(const test::TempDir& dir, int frames) {
  const fs::path folder = dir / "synthetic";
  test::writeSyntheticSequence(folder, frames);
  return folder;
}

// ---- the fr1_xyz clip: a bag gives the folder's run -------------------------------------------

TEST(BagSequence, Fr1XyzClipAsBagGivesTheFoldersDeterministicTrajectory) {
  const fs::path clip = test::clipDir("fr1_xyz_0000_0099");
  DESSLAM_REQUIRE_SHARED(clip);
  constexpr size_t kFrames = 40;
  SystemOptions options = io::loadConfig(test::sourceDir() / "config" / "tum_fr1.yaml");
  options.semantic.segmenter = SegmenterKind::kNone;  // the network is not what is compared, and slow
  options.dynamic.mode = DynamicMode::kGeometric;
  options.dense.enabled = false;

  const test::TempDir dir;
  const io::TumSequence folder = io::TumSequence::open(clip);
  const fs::path bag_file = dir / "rgbd_dataset_freiburg1_xyz.bag";
  BagWriteOptions write;
  write.max_frames = kFrames;  // 32FC1 metres, bz2 chunks: the defaults, TUM's layout
  writeBag(folder, options.camera, bag_file, write);
  fs::copy_file(clip / "groundtruth.txt", dir / "rgbd_dataset_freiburg1_xyz-groundtruth.txt");

  const BagSequence bag = BagSequence::open(bag_file, options.bag);
  ASSERT_EQ(bag.size(), kFrames);
  for (size_t i = 0; i < kFrames; ++i) {
    EXPECT_EQ(bag.rgbTimestamp(i), folder.rgbTimestamp(i)) << "frame " << i;
    EXPECT_EQ(bag.depthTimestamp(i), folder.depthTimestamp(i)) << "frame " << i;
  }
  for (size_t i : {size_t{0}, kFrames / 2, kFrames - 1}) {
    const io::RgbdImage from_bag = bag.load(i, options.camera);
    const io::RgbdImage from_folder = folder.load(i, options.camera);
    EXPECT_TRUE(identical(from_bag.bgr, from_folder.bgr)) << "RGB of frame " << i;
    EXPECT_TRUE(identical(from_bag.depth, from_folder.depth)) << "depth of frame " << i;
  }
  ASSERT_TRUE(bag.groundTruth().has_value()) << "the -groundtruth.txt beside the bag was not read";
  EXPECT_EQ(bag.groundTruth()->size(), folder.groundTruth()->size());

  const Trajectory from_folder = test::runOver(folder, options, kFrames).camera;
  const Trajectory from_bag = test::runOver(bag, options, kFrames).camera;
  EXPECT_GE(from_folder.size(), kFrames - 2) << "the folder run itself lost frames";
  expectSameTrajectory(from_bag, from_folder);
  const eval::AteResult ate = eval::computeAte(*bag.groundTruth(), from_bag);
  std::printf("fr1_xyz clip, %zu frames from a bz2 bag: ATE RMSE %.2f mm\n", kFrames, 1000 * ate.translation_m.rmse);
}

// ---- synthetic scenes ------------------------------------------------------------------------

TEST(BagSequence, MillimetreDepthIsTrackedLikeTheFolder) {
  const test::TempDir dir;
  constexpr int kFrames = 30;
  const fs::path folder_dir = writeSyntheticFolder(dir, kFrames);
  const io::TumSequence folder = io::TumSequence::open(folder_dir);
  const SystemOptions options = test::syntheticSystemOptions();
  BagWriteOptions write;
  write.depth_millimetres = true;
  write.bz2_chunks = false;
  writeBag(folder, options.camera, dir / "mm.bag", write);
  fs::copy_file(folder_dir / "groundtruth.txt", dir / "groundtruth.txt");

  const BagSequence bag = BagSequence::open(dir / "mm.bag", options.bag);
  ASSERT_EQ(bag.size(), folder.size());
  // 16UC1 is millimetres: within half a millimetre of the folder's depth, no reading stays none.
  for (size_t i : {size_t{0}, size_t{kFrames - 1}}) {
    const cv::Mat from_bag = bag.load(i, options.camera).depth;
    const cv::Mat from_folder = folder.load(i, options.camera).depth;
    ASSERT_EQ(from_bag.type(), CV_32FC1);
    cv::Mat difference;
    cv::absdiff(from_bag, from_folder, difference);
    double worst = 0;
    cv::minMaxLoc(difference, nullptr, &worst);
    EXPECT_LE(worst, 0.0005 + 1e-6) << "frame " << i;
    EXPECT_EQ(cv::countNonZero(from_bag == 0), cv::countNonZero(from_folder == 0)) << "frame " << i;
    EXPECT_GT(cv::countNonZero(from_bag), 0);
  }
  ASSERT_TRUE(bag.groundTruth().has_value()) << "groundtruth.txt beside the bag was not read";
  const Trajectory trajectory = test::runOver(bag, options).camera;
  EXPECT_EQ(trajectory.size(), bag.size());
  const eval::AteResult ate = eval::computeAte(*bag.groundTruth(), trajectory);
  EXPECT_LT(ate.translation_m.rmse, 0.01) << "ATE RMSE on millimetre depth";
}

TEST(BagSequence, CameraInfoGivesTheCalibrationAndOpenSequencePicksTheInput) {
  const test::TempDir dir;
  const fs::path folder_dir = writeSyntheticFolder(dir, 3);
  CameraOptions camera = sim::syntheticCamera();
  camera.distortion = {0.1, -0.2, 0.001, 0.002, 0.3};  // written out as plumb_bob
  writeBag(io::TumSequence::open(folder_dir), camera, dir / "s.bag");

  const auto bag = openSequence(dir / "s.bag", BagOptions{});
  EXPECT_NE(dynamic_cast<const BagSequence*>(bag.get()), nullptr);
  const io::InputCalibration calibration = bag->calibration();
  EXPECT_EQ(calibration.fx, camera.fx);
  EXPECT_EQ(calibration.fy, camera.fy);
  EXPECT_EQ(calibration.cx, camera.cx);
  EXPECT_EQ(calibration.cy, camera.cy);
  EXPECT_EQ(calibration.width, camera.width);
  EXPECT_EQ(calibration.height, camera.height);
  EXPECT_EQ(calibration.distortion, camera.distortion);
  EXPECT_CONTAINS(calibration.source, "/camera/rgb/camera_info");
  EXPECT_EQ(bag->frameName(0).find('.') != std::string::npos, true) << bag->frameName(0);

  const auto folder = openSequence(folder_dir, BagOptions{});
  EXPECT_NE(dynamic_cast<const io::TumSequence*>(folder.get()), nullptr);
  EXPECT_CONTAINS(inputErrorOf([&] { folder->calibration(); }), "camera.fx");
}

// ---- errors -----------------------------------------------------------------------------------

TEST(BagSequence, NotABagIsAnErrorNamingTheFile) {
  const test::TempDir dir;
  const fs::path text = dir.write("notes.bag", "this is not a bag\n");
  const std::string message = inputErrorOf([&] { BagSequence::open(text, BagOptions{}); });
  EXPECT_CONTAINS(message, "notes.bag");
  EXPECT_CONTAINS(message, "ROS 1 bag");
  // Through openSequence: any file is read as a bag, a missing .bag is named as a bag.
  EXPECT_CONTAINS(inputErrorOf([&] { openSequence(dir.write("list.txt", "1 a.png\n"), BagOptions{}); }), "ROS 1 bag");
  const std::string missing = inputErrorOf([&] { openSequence(dir / "nothing_here.bag", BagOptions{}); });
  EXPECT_CONTAINS(missing, "nothing_here.bag");
  EXPECT_CONTAINS(missing, "does not exist");
}

TEST(BagSequence, MissingTopicListsTheBagsTopicsAndTheOption) {
  const test::TempDir dir;
  const fs::path folder_dir = writeSyntheticFolder(dir, 2);
  BagWriteOptions write;
  write.topics.depth_topic = "/kinect/depth_registered/image";
  write.camera_info = false;
  const CameraOptions camera = sim::syntheticCamera();
  writeBag(io::TumSequence::open(folder_dir), camera, dir / "other.bag", write);

  const std::string message = inputErrorOf([&] { BagSequence::open(dir / "other.bag", BagOptions{}); });
  EXPECT_CONTAINS(message, "other.bag");
  EXPECT_CONTAINS(message, "/camera/depth/image");
  EXPECT_CONTAINS(message, "bag.depth_topic");
  EXPECT_CONTAINS(message, "/kinect/depth_registered/image (sensor_msgs/Image)");

  // With the topic set it opens; camera_info is missing, which only matters for the calibration.
  BagOptions topics;
  topics.depth_topic = write.topics.depth_topic;
  const BagSequence bag = BagSequence::open(dir / "other.bag", topics);
  EXPECT_EQ(bag.size(), 2u);
  const std::string no_info = inputErrorOf([&] { bag.calibration(); });
  EXPECT_CONTAINS(no_info, "/camera/rgb/camera_info");
  EXPECT_CONTAINS(no_info, "bag.camera_info_topic");

  // A topic of another type.
  BagOptions wrong_type;
  wrong_type.depth_topic = write.topics.depth_topic;
  wrong_type.camera_info_topic = "/camera/rgb/image_color";
  const BagSequence images = BagSequence::open(dir / "other.bag", wrong_type);
  EXPECT_CONTAINS(inputErrorOf([&] { images.calibration(); }), "expected sensor_msgs/CameraInfo");
}

TEST(BagSequence, UnsupportedEncodingAndWrongSizeNameTheTopicAndTheFix) {
  const test::TempDir dir;
  const CameraOptions camera = sim::syntheticCamera();
  {
    BagWriter writer(dir / "mono.bag", /*bz2_chunks=*/true);
    const RosTime stamp{100, 0};
    writer.write("/camera/rgb/image_color",
                 imageMessage(cv::Mat(camera.height, camera.width, CV_8UC1, cv::Scalar(7)), "mono8", stamp));
    writer.write("/camera/depth/image",
                 imageMessage(cv::Mat(camera.height, camera.width, CV_32FC1, cv::Scalar(1.5f)), "32FC1", stamp));
    writer.close();
  }
  const BagSequence bag = BagSequence::open(dir / "mono.bag", BagOptions{});
  const std::string encoding = inputErrorOf([&] { bag.load(0, camera); });
  EXPECT_CONTAINS(encoding, "mono.bag");
  EXPECT_CONTAINS(encoding, "/camera/rgb/image_color");
  EXPECT_CONTAINS(encoding, "'mono8'");
  EXPECT_CONTAINS(encoding, "rgb8 or bgr8");

  CameraOptions other = camera;
  other.width = camera.width * 2;
  const std::string size = inputErrorOf([&] { bag.load(0, other); });
  EXPECT_CONTAINS(size, "camera.width x camera.height");
  EXPECT_CONTAINS(size, "camera_info");

  {
    BagWriter writer(dir / "depth8.bag", /*bz2_chunks=*/false);
    const RosTime stamp{100, 0};
    writer.write("/camera/rgb/image_color",
                 imageMessage(cv::Mat(camera.height, camera.width, CV_8UC3, cv::Scalar(1, 2, 3)), "rgb8", stamp));
    writer.write("/camera/depth/image",
                 imageMessage(cv::Mat(camera.height, camera.width, CV_8UC1, cv::Scalar(1)), "mono8", stamp));
    writer.close();
  }
  const std::string depth = inputErrorOf([&] { BagSequence::open(dir / "depth8.bag", BagOptions{}).load(0, camera); });
  EXPECT_CONTAINS(depth, "/camera/depth/image");
  EXPECT_CONTAINS(depth, "32FC1 (metres) or 16UC1 (millimetres)");
}

}  // namespace
}  // namespace desslam::bag
