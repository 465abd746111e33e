// The semantic thread: segments frame k on its own worker while tracking extracts ORB features
// of frame k, so the network's latency overlaps with feature extraction.
//
// Modes
//   kOffline:  every submitted frame is segmented; submit() blocks while 2 frames already wait;
//              waitFor(k) blocks until frame k's result is ready (reproducible runs).
//   kRealtime: submit() never blocks; a frame still waiting when a newer one arrives is dropped
//              (the network always works on the newest frame); latest(k) never waits and hands
//              back the newest finished result with id <= k, which tracking carries forward;
//              waitUntilFinished(k, timeout) waits a bounded time for a frame being segmented.
//
// Lock discipline: one mutex (mutex_) guards the pending input, finished results, in-flight ids,
// counters and the stop flag; three condition variables wait on it. join_mutex_ only serialises
// joining the worker in stop() and is never held together with mutex_.
// The Segmenter is touched only by the worker thread and is called with the mutex released, so
// submit()/latest() never wait for the network. Results are immutable shared objects: a caller
// keeps its shared_ptr as long as it likes after the thread has forgotten it.
//
// Memory: a result is erased once consumed (waitFor) or when it is older than the newest result
// handed out by latest(); at most kMaxRealtimeResults finished results are kept in real-time mode.
//
// Own masks (requestOwnMask/waitForOwnMask): a frame's own mask when a carried one will not do
// (a keyframe made while the mask was carried forward, before local mapping uses it; a frame
// while tracking is lost). The request is kept apart from the frame stream: a requested frame is
// never dropped, jumps ahead of the stream's frames and is not held back by the real-time rate
// limit; its result stays until waitForOwnMask() takes it.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include <opencv2/core/mat.hpp>

#include "semantic/segmenter.hpp"

namespace desslam::semantic {

enum class SemanticMode { kOffline, kRealtime };

class SemanticThread {
 public:
  static constexpr std::size_t kInputCapacity = 2;        // offline: submit() blocks beyond this
  static constexpr std::size_t kMaxRealtimeResults = 4;   // real-time: older results are dropped

  // segmenter must not be null (throws std::invalid_argument). Starts the worker.
  // realtime_max_rate_hz (real-time mode only; 0 = unlimited): segmentations start at most this
  // often, so the network leaves CPU to tracking and mapping; frames in between get the newest
  // mask carried forward.
  SemanticThread(std::unique_ptr<Segmenter> segmenter, SemanticMode mode, double realtime_max_rate_hz = 0);
  ~SemanticThread();  // stop() and join
  SemanticThread(const SemanticThread&) = delete;
  SemanticThread& operator=(const SemanticThread&) = delete;

  // Queues a frame. frame_id must increase from call to call (InputError otherwise). The image is
  // shared, not copied: the caller must not write to its pixels afterwards. After stop() the frame
  // is ignored.
  void submit(std::uint64_t frame_id, std::shared_ptr<const cv::Mat> bgr, std::string frame_name);

  // Blocks until frame_id's result is ready and returns it; results of older frames are erased.
  // A frame not submitted yet is waited for (another thread may submit it). Returns nullptr when
  // the frame was dropped (real-time), its result was already erased, or stop() was called.
  // If the segmenter threw for this frame, rethrows that exception here.
  std::shared_ptr<const Segmentation> waitFor(std::uint64_t frame_id);

  // Real time: waits at most `timeout` for frame_id's result while the network works on it or is
  // about to start it (not while it rests for the rate limit); returns whether it is finished.
  // Take it with latest(). Returns false at once for a frame dropped or never going to start.
  bool waitUntilFinished(std::uint64_t frame_id, std::chrono::steady_clock::duration timeout);

  // Never waits: the newest finished result with id <= frame_id (nullptr if none yet), its id in
  // *result_frame_id (if not null). Older results are erased. Rethrows a segmenter exception of a
  // frame with id <= frame_id (once).
  std::shared_ptr<const Segmentation> latest(std::uint64_t frame_id, std::uint64_t* result_frame_id);

  // Stops the worker after the frame it is on (waiting frames are discarded), wakes every waiting
  // caller (they return nullptr) and joins. Idempotent.
  void stop();

  // Asks for frame_id's own mask (any thread; never waits). Uses the frame's result when it is
  // finished or being computed, else segments `bgr` before any frame of the stream.
  void requestOwnMask(std::uint64_t frame_id, std::shared_ptr<const cv::Mat> bgr, std::string frame_name);
  // Blocks until the requested frame's result is ready and hands it over (erased here). Returns
  // nullptr at once for a frame never requested (or already taken), and after stop(). Rethrows
  // the segmenter's exception for that frame.
  std::shared_ptr<const Segmentation> waitForOwnMask(std::uint64_t frame_id);
  std::size_t ownMaskRequestCount() const;       // requestOwnMask() calls
  std::size_t ownMaskSegmentationCount() const;  // of those, frames the stream had dropped (segmented for it)

  SemanticMode mode() const { return mode_; }
  std::size_t segmentedCount() const;  // frames segmented successfully
  std::size_t droppedCount() const;    // frames dropped unsegmented (real-time mode, or at stop())
  std::size_t storedResultCount() const;  // finished results not yet erased (memory check)

 private:
  struct Job {
    std::uint64_t frame_id;
    std::shared_ptr<const cv::Mat> bgr;
    std::string frame_name;
    std::chrono::steady_clock::time_point submitted{};
  };
  struct Finished {
    std::shared_ptr<const Segmentation> result;
    std::exception_ptr error;  // set when the segmenter threw
  };

  void run();  // the worker loop

  std::unique_ptr<Segmenter> segmenter_;  // worker thread only
  const SemanticMode mode_;
  const double realtime_max_rate_hz_;

  mutable std::mutex mutex_;
  std::condition_variable job_available_;  // worker waits: pending_ non-empty or stopping
  std::condition_variable space_available_;  // offline submit() waits: pending_ below capacity
  std::condition_variable result_ready_;   // waitFor() waits: its result, its drop, or stopping
  std::deque<Job> pending_;
  std::deque<Job> priority_jobs_;      // own-mask requests not yet started (before pending_)
  std::set<std::uint64_t> own_mask_wanted_;  // requested, result not in own_mask_results_ yet
  std::map<std::uint64_t, Finished> own_mask_results_;  // until waitForOwnMask() takes them
  std::size_t own_mask_requests_ = 0;
  std::size_t own_mask_segmentations_ = 0;
  std::map<std::uint64_t, Finished> finished_;
  std::set<std::uint64_t> in_flight_;  // submitted, not finished and not dropped
  bool any_submitted_ = false;
  std::uint64_t last_submitted_id_ = 0;
  // Real time, rate-limited: the worker rests between segmentations. After a rest it starts only
  // on a frame submitted at most a quarter of the usual interval between submissions before the
  // rest ended (its tracking may still wait for it, see waitUntilFinished); an older one was
  // tracked with a carried mask already and is dropped for the next.
  bool resting_ = false;
  std::chrono::steady_clock::time_point rest_ended_{};
  std::chrono::steady_clock::time_point last_submit_time_{};
  double submit_interval_s_ = 0;  // running mean of the time between submissions
  bool stopping_ = false;
  std::size_t segmented_ = 0;
  std::size_t dropped_ = 0;

  std::mutex join_mutex_;  // serialises worker_.join() (not part of the discipline above)
  std::thread worker_;  // declared last: starts after every member above is constructed
};

}  // namespace desslam::semantic
