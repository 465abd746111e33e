// One worker thread consuming a BoundedQueue in order: the shape the local-mapping and
// loop-closing threads share (queue, count of items queued or in work, wait until idle, stop,
// and the worker's exception).
//
// An exception thrown by `process` does not end the program: the worker keeps it
// (std::exception_ptr, failure()), processes nothing more (it still takes queued items off the
// queue, so a blocked producer is released) and becomes idle; the thread driving the pipeline
// reads failure() and rethrows it to its caller. push() then refuses items.
//
// Locks: the queue's own mutex guards the queue; state_mutex_ guards failure_ and is the mutex of
// the idle wait (pending_ is an atomic changed under it, so a waiter never misses a wake-up).
// process runs with neither held.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

#include "core/bounded_queue.hpp"

namespace desslam {

template <class T>
class QueueWorker {
 public:
  using Process = std::function<void(T&)>;

  // Starts the thread. `name` names it in messages ("local mapping").
  QueueWorker(std::string name, std::size_t capacity, QueueFullPolicy policy, Process process)
      : name_(std::move(name)), process_(std::move(process)), queue_(capacity, policy), worker_([this] { run(); }) {}
  ~QueueWorker() { stop(); }
  QueueWorker(const QueueWorker&) = delete;
  QueueWorker& operator=(const QueueWorker&) = delete;

  // Any thread. False when the item was not queued (stopped, or the worker failed): it is never
  // processed and not counted. With kDropOldest, an item pushed out of the queue is uncounted.
  bool push(T item) {
    if (failed_.load()) return false;
    const std::size_t dropped_before = queue_.dropped();
    ++pending_;  // counted first so waitUntilIdle() never misses an item in flight
    if (!queue_.push(std::move(item))) {
      finished(1);
      return false;
    }
    const std::size_t dropped_now = queue_.dropped();
    if (dropped_now > dropped_before) finished(static_cast<int>(dropped_now - dropped_before));
    return true;
  }

  // Items queued or being processed.
  int pending() const { return pending_.load(); }
  // Items waiting in the queue (not the one being processed).
  std::size_t queued() const { return queue_.size(); }
  std::size_t dropped() const { return queue_.dropped(); }

  // Blocks until every item pushed so far is processed or dropped (or the worker failed).
  void waitUntilIdle() {
    std::unique_lock lock(state_mutex_);
    idle_cv_.wait(lock, [&] { return pending_.load() <= 0; });
  }

  // Closes the queue, processes what is left (nothing after a failure), joins. Idempotent; one
  // thread at a time (the pipeline's owner).
  void stop() {
    queue_.close();
    if (worker_.joinable()) worker_.join();
  }

  // The exception `process` threw (null while none did). Any thread.
  std::exception_ptr failure() const {
    std::lock_guard lock(state_mutex_);
    return failure_;
  }
  const std::string& name() const { return name_; }

 private:
  void finished(int count) {
    {
      std::lock_guard lock(state_mutex_);
      pending_ -= count;
    }
    idle_cv_.notify_all();
  }

  void run() {
    while (auto item = queue_.pop()) {
      if (!failed_.load()) {
        try {
          process_(*item);
        } catch (...) {
          std::lock_guard lock(state_mutex_);
          failure_ = std::current_exception();
          failed_ = true;
        }
      }
      finished(1);
    }
  }

  const std::string name_;
  const Process process_;
  BoundedQueue<T> queue_;
  std::atomic<int> pending_{0};
  std::atomic<bool> failed_{false};
  mutable std::mutex state_mutex_;
  std::condition_variable idle_cv_;
  std::exception_ptr failure_;  // guarded by state_mutex_
  std::thread worker_;          // last: starts after every member above exists
};

}  // namespace desslam
