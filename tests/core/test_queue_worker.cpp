// The worker thread shared by local mapping and loop closing: idle accounting and exceptions.
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "core/queue_worker.hpp"

namespace desslam {
namespace {

TEST(QueueWorker, ProcessesEveryItemInOrder) {
  std::vector<int> seen;  // written by the worker only; read after waitUntilIdle
  QueueWorker<int> worker("test", 2, QueueFullPolicy::kBlock, [&](int& v) { seen.push_back(v); });
  for (int i = 0; i < 50; ++i) EXPECT_TRUE(worker.push(i));
  worker.waitUntilIdle();
  EXPECT_EQ(worker.pending(), 0);
  ASSERT_EQ(seen.size(), 50u);
  for (int i = 0; i < 50; ++i) EXPECT_EQ(seen[static_cast<size_t>(i)], i);
}

// An exception in the worker is kept (not std::terminate), the worker goes idle and refuses more.
TEST(QueueWorker, ExceptionReachesTheOwnerAndTheWorkerGoesIdle) {
  std::atomic<int> processed{0};
  QueueWorker<int> worker("test", 2, QueueFullPolicy::kBlock, [&](int& v) {
    if (v == 3) throw InputError("item 3 is bad");
    ++processed;
  });
  for (int i = 0; i < 10; ++i) worker.push(i);  // never blocks forever: failed items are drained
  worker.waitUntilIdle();
  EXPECT_EQ(worker.pending(), 0);
  EXPECT_EQ(processed.load(), 3);
  ASSERT_TRUE(worker.failure());
  EXPECT_EQ(exceptionMessage(worker.failure()), "item 3 is bad");
  EXPECT_THROW(std::rethrow_exception(worker.failure()), InputError);
  EXPECT_FALSE(worker.push(11));
  EXPECT_EQ(worker.pending(), 0);
}

// A push after stop() is refused and not counted (LocalMappingThread used to count it, so
// waitUntilIdle() never returned).
TEST(QueueWorker, PushAfterStopIsNotCounted) {
  QueueWorker<int> worker("test", 2, QueueFullPolicy::kBlock, [](int&) {});
  worker.stop();
  EXPECT_FALSE(worker.push(1));
  EXPECT_EQ(worker.pending(), 0);
  worker.waitUntilIdle();  // returns
}

TEST(QueueWorker, DroppedItemsAreNotPending) {
  std::atomic<bool> release{false};
  QueueWorker<int> worker("test", 2, QueueFullPolicy::kDropOldest, [&](int&) {
    while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  });
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(worker.push(i));
  EXPECT_LE(worker.pending(), 3);  // at most one in work and two queued
  release = true;
  worker.waitUntilIdle();
  EXPECT_EQ(worker.pending(), 0);
  EXPECT_GE(worker.dropped(), 7u);
}

}  // namespace
}  // namespace desslam
