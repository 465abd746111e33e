// Bounded multi-producer/multi-consumer queue between pipeline stages.
//
// Lock discipline: one mutex guards the deque and the closed flag; both condition variables
// wait on it. Messages should be immutable (shared_ptr<const T>) so that a consumer never
// races with the producer that made them.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>

namespace desslam {

enum class QueueFullPolicy {
  kBlock,       // offline mode: the producer waits (every message is processed)
  kDropOldest,  // real-time mode: the oldest message is discarded to make room
};

template <class T>
class BoundedQueue {
 public:
  BoundedQueue(std::size_t capacity, QueueFullPolicy policy) : capacity_(capacity), policy_(policy) {}

  // Returns false when the queue is closed (the message is not enqueued).
  bool push(T value) {
    std::unique_lock lock(mutex_);
    if (policy_ == QueueFullPolicy::kBlock)
      not_full_.wait(lock, [&] { return closed_ || items_.size() < capacity_; });
    if (closed_) return false;
    if (policy_ == QueueFullPolicy::kDropOldest && items_.size() >= capacity_) {
      items_.pop_front();
      ++dropped_;
    }
    items_.push_back(std::move(value));
    not_empty_.notify_one();
    return true;
  }

  // Blocks until a message arrives; std::nullopt once closed and drained.
  std::optional<T> pop() {
    std::unique_lock lock(mutex_);
    not_empty_.wait(lock, [&] { return closed_ || !items_.empty(); });
    if (items_.empty()) return std::nullopt;
    T value = std::move(items_.front());
    items_.pop_front();
    not_full_.notify_one();
    return value;
  }

  std::optional<T> tryPop() {
    std::lock_guard lock(mutex_);
    if (items_.empty()) return std::nullopt;
    T value = std::move(items_.front());
    items_.pop_front();
    not_full_.notify_one();
    return value;
  }

  // No more pushes; consumers drain what is left, then pop() returns std::nullopt.
  void close() {
    std::lock_guard lock(mutex_);
    closed_ = true;
    not_empty_.notify_all();
    not_full_.notify_all();
  }

  std::size_t size() const {
    std::lock_guard lock(mutex_);
    return items_.size();
  }
  std::size_t dropped() const {
    std::lock_guard lock(mutex_);
    return dropped_;
  }

 private:
  const std::size_t capacity_;
  const QueueFullPolicy policy_;
  mutable std::mutex mutex_;
  std::condition_variable not_empty_;
  std::condition_variable not_full_;
  std::deque<T> items_;
  bool closed_ = false;
  std::size_t dropped_ = 0;
};

}  // namespace desslam
