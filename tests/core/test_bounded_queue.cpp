// BoundedQueue: FIFO order, the two full-queue policies, and close() waking waiting threads.
// Blocking is checked by state (the producer has not returned while the queue is full), never
// by how long something took.
#include "core/bounded_queue.hpp"

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace desslam {
namespace {

using namespace std::chrono_literals;

TEST(BoundedQueue, PopsInPushOrder) {
  BoundedQueue<int> queue(4, QueueFullPolicy::kBlock);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(queue.push(i));
  EXPECT_EQ(queue.size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(queue.pop(), i);
  EXPECT_EQ(queue.size(), 0u);
  EXPECT_EQ(queue.tryPop(), std::nullopt);
}

TEST(BoundedQueue, BlockPolicyWaitsWhileFull) {
  BoundedQueue<int> queue(2, QueueFullPolicy::kBlock);
  ASSERT_TRUE(queue.push(1));
  ASSERT_TRUE(queue.push(2));
  std::atomic<bool> pushed{false};
  std::thread producer([&] {
    queue.push(3);
    pushed = true;
  });
  // Give the producer ample chance to (wrongly) get through.
  std::this_thread::sleep_for(100ms);
  EXPECT_FALSE(pushed.load()) << "push() returned although the queue was full";
  EXPECT_EQ(queue.size(), 2u);
  EXPECT_EQ(queue.pop(), 1);  // makes room
  producer.join();
  EXPECT_TRUE(pushed.load());
  EXPECT_EQ(queue.pop(), 2);
  EXPECT_EQ(queue.pop(), 3);
  EXPECT_EQ(queue.dropped(), 0u);
}

TEST(BoundedQueue, BlockPolicyLosesNothingUnderLoad) {
  BoundedQueue<int> queue(3, QueueFullPolicy::kBlock);
  constexpr int kCount = 2000;
  std::thread producer([&] {
    for (int i = 0; i < kCount; ++i) queue.push(i);
    queue.close();
  });
  std::vector<int> received;
  while (auto v = queue.pop()) received.push_back(*v);
  producer.join();
  ASSERT_EQ(received.size(), static_cast<size_t>(kCount));
  for (int i = 0; i < kCount; ++i) ASSERT_EQ(received[i], i);
}

TEST(BoundedQueue, DropOldestDropsAndCounts) {
  BoundedQueue<int> queue(3, QueueFullPolicy::kDropOldest);
  for (int i = 1; i <= 5; ++i) EXPECT_TRUE(queue.push(i));  // never blocks
  EXPECT_EQ(queue.size(), 3u);
  EXPECT_EQ(queue.dropped(), 2u);
  EXPECT_EQ(queue.pop(), 3);  // 1 and 2 were dropped
  EXPECT_EQ(queue.pop(), 4);
  EXPECT_EQ(queue.pop(), 5);
  EXPECT_TRUE(queue.push(6));
  EXPECT_EQ(queue.dropped(), 2u);  // room again: nothing more dropped
}

TEST(BoundedQueue, CloseWakesAWaitingConsumer) {
  BoundedQueue<int> queue(2, QueueFullPolicy::kBlock);
  std::atomic<bool> returned{false};
  std::optional<int> result = 42;
  std::thread consumer([&] {
    result = queue.pop();
    returned = true;
  });
  std::this_thread::sleep_for(50ms);
  EXPECT_FALSE(returned.load()) << "pop() returned from an empty, open queue";
  queue.close();
  consumer.join();  // would hang if close() did not wake it
  EXPECT_TRUE(returned.load());
  EXPECT_EQ(result, std::nullopt);
}

TEST(BoundedQueue, CloseWakesEveryConsumer) {
  BoundedQueue<int> queue(2, QueueFullPolicy::kDropOldest);
  std::atomic<int> finished{0};
  std::vector<std::thread> consumers;
  for (int i = 0; i < 4; ++i)
    consumers.emplace_back([&] {
      while (queue.pop()) {
      }
      ++finished;
    });
  queue.close();
  for (auto& t : consumers) t.join();
  EXPECT_EQ(finished.load(), 4);
}

TEST(BoundedQueue, CloseWakesABlockedProducerWhichFails) {
  BoundedQueue<int> queue(1, QueueFullPolicy::kBlock);
  ASSERT_TRUE(queue.push(1));
  std::atomic<int> push_result{-1};
  std::thread producer([&] { push_result = queue.push(2) ? 1 : 0; });
  std::this_thread::sleep_for(50ms);
  EXPECT_EQ(push_result.load(), -1);
  queue.close();
  producer.join();
  EXPECT_EQ(push_result.load(), 0);
}

TEST(BoundedQueue, ClosedQueueDrainsThenEnds) {
  BoundedQueue<std::shared_ptr<const int>> queue(4, QueueFullPolicy::kBlock);
  queue.push(std::make_shared<const int>(7));
  queue.push(std::make_shared<const int>(8));
  queue.close();
  EXPECT_FALSE(queue.push(std::make_shared<const int>(9)));  // refused after close
  auto a = queue.pop();
  auto b = queue.pop();
  ASSERT_TRUE(a && b);
  EXPECT_EQ(**a, 7);
  EXPECT_EQ(**b, 8);
  EXPECT_EQ(queue.pop(), std::nullopt);
  EXPECT_EQ(queue.tryPop(), std::nullopt);
}

TEST(BoundedQueue, DropOldestRefusesAfterCloseWithoutDropping) {
  BoundedQueue<int> queue(1, QueueFullPolicy::kDropOldest);
  ASSERT_TRUE(queue.push(1));
  queue.close();
  EXPECT_FALSE(queue.push(2));
  // A refused push must not have cost the message that was already queued.
  EXPECT_EQ(queue.pop(), 1);
  EXPECT_EQ(queue.dropped(), 0u);
}

}  // namespace
}  // namespace desslam
