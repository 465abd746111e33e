#include "io/frame_prefetcher.hpp"

#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.hpp"

namespace desslam::io {
namespace {

// A sequence of `size` frames whose image k is filled with the value k % 256; loading frame
// `failing` throws. Records which frames were loaded.
class CountingSequence : public RgbdSequence {
 public:
  CountingSequence(std::size_t size, std::size_t failing = SIZE_MAX) : size_(size), failing_(failing) {}
  std::size_t size() const override { return size_; }
  Timestamp rgbTimestamp(std::size_t i) const override { return 0.1 * static_cast<double>(i); }
  Timestamp depthTimestamp(std::size_t i) const override { return rgbTimestamp(i); }
  std::string frameName(std::size_t i) const override { return std::to_string(i) + ".png"; }
  RgbdImage load(std::size_t i, const CameraOptions&) const override {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    if (i == failing_) throw InputError("frame " + std::to_string(i) + " is unreadable");
    std::lock_guard lock(mutex_);
    loaded_.insert(i);
    RgbdImage image;
    image.timestamp = rgbTimestamp(i);
    image.bgr = cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(static_cast<double>(i % 256)));
    image.depth = cv::Mat(4, 4, CV_32F, cv::Scalar(1.0));
    return image;
  }
  std::set<std::size_t> loaded() const {
    std::lock_guard lock(mutex_);
    return loaded_;
  }
  const std::optional<Trajectory>& groundTruth() const override { return no_ground_truth_; }
  const std::string& groundTruthProblem() const override { return no_problem_; }
  std::vector<std::string> warnings() const override { return {}; }
  InputCalibration calibration() const override { throw InputError("no calibration"); }
  std::string description() const override { return "counting sequence"; }

 private:
  std::size_t size_, failing_;
  mutable std::mutex mutex_;
  mutable std::set<std::size_t> loaded_;
  std::optional<Trajectory> no_ground_truth_;
  std::string no_problem_;
};

std::set<std::size_t> waitForLoads(const CountingSequence& sequence, std::size_t count) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (sequence.loaded().size() < count && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // time to load more, if it would
  return sequence.loaded();
}

TEST(FramePrefetcher, GivesTheListedFramesInOrderAndSkipsTheOthers) {
  CountingSequence sequence(20);
  const std::vector<std::size_t> indices{0, 1, 2, 5, 6, 7, 12, 19};
  FramePrefetcher prefetcher(sequence, CameraOptions{}, indices, 3);
  for (std::size_t i : indices) {
    const RgbdImage image = prefetcher.take(i);
    EXPECT_DOUBLE_EQ(image.timestamp, sequence.rgbTimestamp(i));
    EXPECT_EQ(image.bgr.at<cv::Vec3b>(0, 0)[0], i % 256);
  }
  EXPECT_EQ(sequence.loaded(), std::set<std::size_t>(indices.begin(), indices.end()));
}

TEST(FramePrefetcher, LoadsAheadButNoFurtherThanAllowed) {
  CountingSequence sequence(50);
  std::vector<std::size_t> indices(50);
  for (std::size_t i = 0; i < indices.size(); ++i) indices[i] = i;
  FramePrefetcher prefetcher(sequence, CameraOptions{}, indices, 4);
  // Nothing taken: four frames wait, the fifth is not loaded.
  EXPECT_EQ(waitForLoads(sequence, 4), (std::set<std::size_t>{0, 1, 2, 3}));
  prefetcher.take(0);
  prefetcher.take(1);
  EXPECT_EQ(waitForLoads(sequence, 6).size(), 6u);
}

TEST(FramePrefetcher, AFailedLoadIsThrownAtItsFrameAfterTheFramesBeforeIt) {
  CountingSequence sequence(10, 4);
  std::vector<std::size_t> indices{0, 1, 2, 3, 4, 5, 6};
  FramePrefetcher prefetcher(sequence, CameraOptions{}, indices, 8);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NO_THROW(prefetcher.take(i)) << i;
  try {
    prefetcher.take(4);
    ADD_FAILURE() << "frame 4 should have thrown";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("frame 4 is unreadable"), std::string::npos);
  }
  EXPECT_EQ(sequence.loaded().count(5), 0u) << "nothing is loaded after a failure";
  EXPECT_THROW(prefetcher.take(5), std::logic_error);
}

TEST(FramePrefetcher, ATakeOutOfOrderIsALogicError) {
  CountingSequence sequence(5);
  FramePrefetcher prefetcher(sequence, CameraOptions{}, {0, 1, 2}, 2);
  EXPECT_THROW(prefetcher.take(1), std::logic_error);
  EXPECT_NO_THROW(prefetcher.take(0));
  EXPECT_THROW(FramePrefetcher(sequence, CameraOptions{}, {0}, 0), std::invalid_argument);
}

TEST(FramePrefetcher, StopsWhenDestroyedWithFramesLeft) {
  CountingSequence sequence(1000);
  std::vector<std::size_t> indices(1000);
  for (std::size_t i = 0; i < indices.size(); ++i) indices[i] = i;
  const auto start = std::chrono::steady_clock::now();
  {
    FramePrefetcher prefetcher(sequence, CameraOptions{}, indices, 2);
    prefetcher.take(0);
  }
  EXPECT_LT(sequence.loaded().size(), 10u);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

}  // namespace
}  // namespace desslam::io
