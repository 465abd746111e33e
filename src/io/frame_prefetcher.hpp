// Loads the frames of a sequence ahead of their use, on a thread of its own, as a camera driver
// delivers decoded frames: decoding (PNG, a bag's messages) overlaps with processing instead of
// taking the consumer's time. `desslam run` reads every sequence through one.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include "core/camera_options.hpp"
#include "io/rgbd_sequence.hpp"

namespace desslam::io {

class FramePrefetcher {
 public:
  // Loads sequence.load(i, camera) for each i of `indices`, in that order, at most `max_ahead`
  // (>= 1) frames ahead of take(). `sequence` must outlive this object.
  FramePrefetcher(const RgbdSequence& sequence, const CameraOptions& camera, std::vector<std::size_t> indices,
                  std::size_t max_ahead);
  ~FramePrefetcher();  // stops loading and joins (a load in progress finishes first)
  FramePrefetcher(const FramePrefetcher&) = delete;
  FramePrefetcher& operator=(const FramePrefetcher&) = delete;

  // The next frame of `indices`, waiting for it when it is not loaded yet. `index` must be that
  // frame's index (std::logic_error otherwise: the caller's loop and the list disagree). Throws
  // what loading it threw (nothing after it is loaded).
  RgbdImage take(std::size_t index);

 private:
  struct Slot {
    std::size_t index = 0;
    RgbdImage image;
    std::exception_ptr error;
  };
  void run();

  const RgbdSequence& sequence_;
  const CameraOptions camera_;
  const std::vector<std::size_t> indices_;
  const std::size_t max_ahead_;

  // Lock discipline: mutex_ guards loaded_, next_taken_, loader_done_ and stopping_. The prefetch
  // thread is the only caller of sequence_.load(); take() and the destructor run on the consumer's
  // thread.
  std::mutex mutex_;
  std::condition_variable loaded_changed_;  // a frame was loaded, or the loader ended
  std::condition_variable space_changed_;   // a frame was taken, or stop
  std::deque<Slot> loaded_;                 // loaded, not yet taken, in indices_ order
  std::size_t next_taken_ = 0;              // position in indices_ of the next take()
  bool loader_done_ = false;                // every frame loaded, or a load failed
  bool stopping_ = false;
  std::thread thread_;  // last: starts after the members above exist
};

}  // namespace desslam::io
