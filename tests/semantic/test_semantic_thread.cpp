#include <atomic>
#include <chrono>
#include <condition_variable>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "semantic/semantic_thread.hpp"

namespace desslam::semantic {
namespace {

using namespace std::chrono_literals;

// Closed until open(): lets a test hold the fake network in the middle of a frame.
class Gate {
 public:
  void open() {
    std::lock_guard lock(mutex_);
    open_ = true;
    cv_.notify_all();
  }
  void pass() {
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [&] { return open_; });
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool open_ = false;
};

// Encodes the frame id: the image carries it in every pixel, the fake copies it into labels and
// marks odd frames fully dynamic. Throws for a frame named "fail.png" (error propagation).
class FakeSegmenter final : public Segmenter {
 public:
  FakeSegmenter(std::chrono::milliseconds delay, Gate* gate = nullptr) : delay_(delay), gate_(gate) {}
  Segmentation segment(const cv::Mat& bgr, const std::string& frame_name) override {
    if (gate_ != nullptr) gate_->pass();
    std::this_thread::sleep_for(delay_);
    const int id = bgr.at<cv::Vec3b>(0, 0)[0];
    if (frame_name == "fail.png") throw InputError("fake failure for " + frame_name);
    Segmentation s;
    s.labels = cv::Mat(bgr.size(), CV_8U, cv::Scalar(id));
    s.dynamic_mask = cv::Mat(bgr.size(), CV_8U, cv::Scalar(id % 2 == 1 ? 255 : 0));
    s.seconds = 1e-3;
    return s;
  }
  std::string name() const override { return "fake"; }

 private:
  std::chrono::milliseconds delay_;
  Gate* gate_;
};

std::shared_ptr<const cv::Mat> frameImage(std::uint64_t id) {
  return std::make_shared<const cv::Mat>(6, 8, CV_8UC3, cv::Scalar(double(id % 256), 0, 0));
}

std::string frameName(std::uint64_t id) { return std::to_string(id) + ".png"; }

int labelOf(const Segmentation& s) { return s.labels.at<std::uint8_t>(0, 0); }

TEST(SemanticThread, OfflineReturnsEveryFrameInOrder) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(2ms), SemanticMode::kOffline);
  constexpr std::uint64_t kFrames = 40;
  std::thread producer([&] {
    for (std::uint64_t id = 1; id <= kFrames; ++id) {
      thread.submit(id, frameImage(id), frameName(id));
    }
  });
  for (std::uint64_t id = 1; id <= kFrames; ++id) {
    const auto result = thread.waitFor(id);
    ASSERT_NE(result, nullptr) << "frame " << id;
    EXPECT_EQ(labelOf(*result), int(id));
    EXPECT_EQ(cv::countNonZero(result->dynamic_mask), id % 2 == 1 ? 48 : 0);
  }
  producer.join();
  EXPECT_EQ(thread.segmentedCount(), kFrames);
  EXPECT_EQ(thread.droppedCount(), 0u);
  EXPECT_EQ(thread.storedResultCount(), 0u);  // every result consumed and erased
}

TEST(SemanticThread, WaitingBeforeSubmitGetsTheFrame) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms), SemanticMode::kOffline);
  auto waiter = std::async(std::launch::async, [&] { return thread.waitFor(3); });
  std::this_thread::sleep_for(20ms);
  for (std::uint64_t id = 1; id <= 3; ++id) thread.submit(id, frameImage(id), frameName(id));
  ASSERT_EQ(waiter.wait_for(10s), std::future_status::ready);
  const auto third = waiter.get();
  ASSERT_NE(third, nullptr);
  EXPECT_EQ(labelOf(*third), 3);
}

TEST(SemanticThread, OfflineSubmitBlocksWhenTwoFramesWait) {
  Gate gate;
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms, &gate), SemanticMode::kOffline);
  std::atomic<int> submitted{0};
  std::thread producer([&] {
    for (std::uint64_t id = 1; id <= 4; ++id) {
      thread.submit(id, frameImage(id), frameName(id));
      ++submitted;
    }
  });
  std::this_thread::sleep_for(100ms);
  // One frame held by the network plus two waiting: the fourth submit cannot have returned.
  EXPECT_LE(submitted.load(), 3);
  gate.open();
  producer.join();
  EXPECT_EQ(submitted.load(), 4);
  for (std::uint64_t id = 1; id <= 4; ++id) ASSERT_NE(thread.waitFor(id), nullptr);
}

TEST(SemanticThread, OlderResultsAreErasedByALaterWait) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms), SemanticMode::kOffline);
  for (std::uint64_t id = 1; id <= 5; ++id) thread.submit(id, frameImage(id), frameName(id));
  const auto fifth = thread.waitFor(5);
  ASSERT_NE(fifth, nullptr);
  EXPECT_EQ(labelOf(*fifth), 5);
  EXPECT_EQ(thread.storedResultCount(), 0u);
  EXPECT_EQ(thread.waitFor(3), nullptr);  // erased (never waited for) -> nullptr, no hang
}

TEST(SemanticThread, SegmenterErrorReachesTheWaiter) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms), SemanticMode::kOffline);
  thread.submit(12, frameImage(12), frameName(12));
  thread.submit(13, frameImage(13), "fail.png");
  thread.submit(14, frameImage(14), frameName(14));
  ASSERT_NE(thread.waitFor(12), nullptr);
  EXPECT_THROW(thread.waitFor(13), InputError);
  const auto after = thread.waitFor(14);  // the thread keeps working after a failed frame
  ASSERT_NE(after, nullptr);
  EXPECT_EQ(labelOf(*after), 14);
}

TEST(SemanticThread, FrameIdsMustIncrease) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms), SemanticMode::kOffline);
  thread.submit(5, frameImage(5), frameName(5));
  EXPECT_THROW(thread.submit(5, frameImage(5), frameName(5)), InputError);
  EXPECT_THROW(thread.submit(6, nullptr, frameName(6)), InputError);
}

TEST(SemanticThread, RealtimeNeverBlocksAndDropsWaitingFrames) {
  Gate gate;
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms, &gate), SemanticMode::kRealtime);
  constexpr std::uint64_t kFrames = 20;
  // All submits happen while the network is stuck on a frame; none may wait for it.
  auto submits = std::async(std::launch::async, [&] {
    for (std::uint64_t id = 1; id <= kFrames; ++id) {
      thread.submit(id, frameImage(id), frameName(id));
      std::uint64_t got = 0;
      EXPECT_EQ(thread.latest(id, &got), nullptr);  // nothing finished yet, and no waiting
    }
  });
  const bool returned = submits.wait_for(10s) == std::future_status::ready;
  gate.open();
  ASSERT_TRUE(returned) << "submit() blocked in real-time mode";
  submits.get();

  // The newest frame is always segmented; poll for it (latest() never waits).
  std::uint64_t result_id = 0;
  std::shared_ptr<const Segmentation> result;
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (result_id != kFrames && std::chrono::steady_clock::now() < deadline) {
    result = thread.latest(kFrames, &result_id);
    std::this_thread::sleep_for(1ms);
  }
  ASSERT_EQ(result_id, kFrames);
  ASSERT_NE(result, nullptr);
  EXPECT_EQ(labelOf(*result), int(kFrames));
  // At most the frame the network held (1, or 2 if it was slow to start) plus the newest ran.
  EXPECT_LE(thread.segmentedCount(), 2u);
  EXPECT_GE(thread.droppedCount(), kFrames - 2);
  EXPECT_EQ(thread.segmentedCount() + thread.droppedCount(), kFrames);
  EXPECT_EQ(thread.waitFor(10), nullptr);  // dropped: returns at once
  EXPECT_LE(thread.storedResultCount(), 1u);
}

TEST(SemanticThread, RealtimeLatestIsNewestAtOrBeforeTheRequest) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms), SemanticMode::kRealtime);
  std::uint64_t got = 0;
  EXPECT_EQ(thread.latest(100, &got), nullptr);
  thread.submit(2, frameImage(2), frameName(2));
  ASSERT_NE(thread.waitFor(2), nullptr);  // waitFor also works in real-time mode (not dropped here)
  thread.submit(4, frameImage(4), frameName(4));
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (thread.storedResultCount() == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(1ms);
  EXPECT_EQ(thread.latest(3, &got), nullptr);  // 2 was consumed; 4 is newer than the request
  const auto four = thread.latest(5, &got);
  ASSERT_NE(four, nullptr);
  EXPECT_EQ(got, 4u);
  const auto again = thread.latest(6, &got);  // still the newest: handed out again
  EXPECT_EQ(again, four);
}

TEST(SemanticThread, RealtimeLatestRethrowsASegmenterError) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms), SemanticMode::kRealtime);
  thread.submit(1, frameImage(1), "fail.png");
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (thread.storedResultCount() == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(1ms);
  std::uint64_t got = 0;
  EXPECT_THROW(thread.latest(1, &got), InputError);
  EXPECT_EQ(thread.latest(1, &got), nullptr);  // reported once
}

TEST(SemanticThread, RealtimeKeepsFewResults) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms), SemanticMode::kRealtime);
  for (std::uint64_t id = 1; id <= 50; ++id) {
    thread.submit(id, frameImage(id), frameName(id));
    std::this_thread::sleep_for(1ms);
    EXPECT_LE(thread.storedResultCount(), SemanticThread::kMaxRealtimeResults);
  }
}

// A keyframe's frame that the real-time stream dropped is segmented for it, ahead of the stream,
// and its result waits for local mapping however many newer frames pass.
TEST(SemanticThread, RealtimeKeyframeRequestSegmentsADroppedFrame) {
  Gate gate;
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms, &gate), SemanticMode::kRealtime);
  for (std::uint64_t id = 1; id <= 5; ++id) thread.submit(id, frameImage(id), frameName(id));
  // The network holds frame 1; 2-4 were dropped by newer frames, 5 waits.
  EXPECT_EQ(thread.waitForOwnMask(3), nullptr) << "not requested: must not wait";
  thread.requestOwnMask(3, frameImage(3), frameName(3));
  gate.open();
  const auto three = thread.waitForOwnMask(3);
  ASSERT_NE(three, nullptr);
  EXPECT_EQ(labelOf(*three), 3);
  EXPECT_EQ(thread.ownMaskRequestCount(), 1u);
  EXPECT_EQ(thread.ownMaskSegmentationCount(), 1u);
  EXPECT_EQ(thread.waitForOwnMask(3), nullptr) << "taken once";
  // The stream goes on: frame 5 is still segmented.
  EXPECT_NE(thread.waitFor(5), nullptr);
}

// A requested frame still waiting in the stream is not dropped by newer frames, nor segmented twice.
TEST(SemanticThread, RealtimeKeyframeRequestKeepsAWaitingFrame) {
  Gate gate;
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms, &gate), SemanticMode::kRealtime);
  thread.submit(1, frameImage(1), frameName(1));
  // Frame 2 waits in the stream (or the worker took it instead of 1): either way it is kept.
  thread.submit(2, frameImage(2), frameName(2));
  thread.requestOwnMask(2, frameImage(2), frameName(2));
  for (std::uint64_t id = 3; id <= 6; ++id) thread.submit(id, frameImage(id), frameName(id));
  gate.open();
  const auto two = thread.waitForOwnMask(2);
  ASSERT_NE(two, nullptr);
  EXPECT_EQ(labelOf(*two), 2);
  EXPECT_EQ(thread.ownMaskSegmentationCount(), 0u) << "the stream's frame was kept, not segmented again";
}

// Offline (emulated latency): the keyframe's result survives the stream's waitFor() of later frames.
TEST(SemanticThread, OfflineKeyframeResultOutlivesLaterWaits) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms), SemanticMode::kOffline);
  thread.submit(1, frameImage(1), frameName(1));
  thread.requestOwnMask(1, frameImage(1), frameName(1));
  thread.submit(2, frameImage(2), frameName(2));
  ASSERT_NE(thread.waitFor(2), nullptr);  // erases frame 1's stream result
  const auto one = thread.waitForOwnMask(1);
  ASSERT_NE(one, nullptr);
  EXPECT_EQ(labelOf(*one), 1);
  EXPECT_EQ(thread.ownMaskSegmentationCount(), 0u) << "the stream's own segmentation served it";
}

TEST(SemanticThread, StopReleasesAKeyframeWaiter) {
  Gate gate;
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms, &gate), SemanticMode::kRealtime);
  thread.submit(1, frameImage(1), frameName(1));
  thread.requestOwnMask(7, frameImage(7), frameName(7));
  auto waiter = std::async(std::launch::async, [&] { return thread.waitForOwnMask(7); });
  std::this_thread::sleep_for(20ms);
  auto stopper = std::async(std::launch::async, [&] { thread.stop(); });
  std::this_thread::sleep_for(20ms);
  gate.open();
  ASSERT_EQ(waiter.wait_for(10s), std::future_status::ready) << "waitForOwnMask() hung after stop()";
  stopper.get();
  EXPECT_EQ(waiter.get(), nullptr);
}

TEST(SemanticThread, StopWhileWaitingReturnsCleanly) {
  Gate gate;
  auto thread = std::make_unique<SemanticThread>(std::make_unique<FakeSegmenter>(0ms, &gate),
                                                 SemanticMode::kOffline);
  thread->submit(1, frameImage(1), frameName(1));
  thread->submit(2, frameImage(2), frameName(2));
  auto waiter = std::async(std::launch::async, [&] { return thread->waitFor(2); });
  auto future_waiter = std::async(std::launch::async, [&] { return thread->waitFor(7); });
  std::this_thread::sleep_for(20ms);  // let the waiters block (they return nullptr either way)
  auto stopper = std::async(std::launch::async, [&] { thread->stop(); });  // joins: waits for frame 1
  ASSERT_EQ(waiter.wait_for(10s), std::future_status::ready) << "waitFor() did not wake on stop()";
  ASSERT_EQ(future_waiter.wait_for(10s), std::future_status::ready);
  EXPECT_EQ(waiter.get(), nullptr);
  EXPECT_EQ(future_waiter.get(), nullptr);  // frame 7 was never submitted
  gate.open();
  ASSERT_EQ(stopper.wait_for(10s), std::future_status::ready);
  stopper.get();
  thread->submit(3, frameImage(3), frameName(3));  // ignored after stop
  EXPECT_EQ(thread->waitFor(3), nullptr);
  thread->stop();  // idempotent
  thread.reset();
}

TEST(SemanticThread, DestructorWithPendingFramesReturns) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(5ms), SemanticMode::kOffline);
  thread.submit(1, frameImage(1), frameName(1));
  thread.submit(2, frameImage(2), frameName(2));
  thread.submit(3, frameImage(3), frameName(3));
}

TEST(SemanticThread, NullSegmenterIsRejected) {
  EXPECT_THROW(SemanticThread(nullptr, SemanticMode::kOffline), std::invalid_argument);
}

// Real time with a rate limit: however fast frames come and the network runs, segmentations
// start at most realtime_max_rate_hz per second (an upper bound: a slow machine only does fewer).
// Real time: tracking may wait a little for the mask of a frame the network is segmenting.
TEST(SemanticThread, RealtimeWaitUntilFinishedGetsTheFrameBeingSegmented) {
  SemanticThread thread(std::make_unique<FakeSegmenter>(30ms), SemanticMode::kRealtime);
  thread.submit(0, frameImage(0), frameName(0));
  ASSERT_TRUE(thread.waitUntilFinished(0, 10s));
  std::uint64_t got = 99;
  const auto result = thread.latest(0, &got);
  ASSERT_NE(result, nullptr);
  EXPECT_EQ(got, 0u);
  EXPECT_EQ(labelOf(*result), 0);
}

TEST(SemanticThread, RealtimeWaitUntilFinishedGivesUpAtTheTimeout) {
  Gate gate;
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms, &gate), SemanticMode::kRealtime);
  thread.submit(0, frameImage(0), frameName(0));
  EXPECT_FALSE(thread.waitUntilFinished(0, 20ms));  // still held by the gate
  gate.open();
  EXPECT_TRUE(thread.waitUntilFinished(0, 10s));
}

TEST(SemanticThread, RealtimeWaitUntilFinishedReturnsAtOnceForADroppedFrame) {
  Gate gate;
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms, &gate), SemanticMode::kRealtime);
  thread.submit(0, frameImage(0), frameName(0));  // the network holds this one
  thread.submit(1, frameImage(1), frameName(1));
  thread.submit(2, frameImage(2), frameName(2));  // drops 1
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(thread.waitUntilFinished(1, 30s));
  EXPECT_LT(std::chrono::steady_clock::now() - start, 20s) << "waited for a dropped frame";
  gate.open();
}

TEST(SemanticThread, RealtimeWaitUntilFinishedDoesNotWaitThroughARest) {
  // One segmentation a minute: after frame 0 the network rests, so frame 1 will not start soon.
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms), SemanticMode::kRealtime, 1.0 / 60.0);
  thread.submit(0, frameImage(0), frameName(0));
  ASSERT_TRUE(thread.waitUntilFinished(0, 10s));
  thread.submit(1, frameImage(1), frameName(1));
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(thread.waitUntilFinished(1, 30s));
  EXPECT_LT(std::chrono::steady_clock::now() - start, 20s) << "waited through the rate limit's rest";
}

TEST(SemanticThread, RealtimeRateLimitBoundsSegmentations) {
  constexpr double kRateHz = 20.0;
  SemanticThread thread(std::make_unique<FakeSegmenter>(0ms), SemanticMode::kRealtime, kRateHz);
  const auto start = std::chrono::steady_clock::now();
  for (std::uint64_t id = 0; id < 150; ++id) {
    thread.submit(id, frameImage(id), frameName(id));
    std::this_thread::sleep_for(2ms);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  thread.stop();
  EXPECT_GE(thread.segmentedCount(), 1u);
  EXPECT_LE(static_cast<double>(thread.segmentedCount()), seconds * kRateHz + 2.0);
}

}  // namespace
}  // namespace desslam::semantic
