#include "semantic/semantic_thread.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "core/error.hpp"
#include "core/thread_priority.hpp"

namespace desslam::semantic {

SemanticThread::SemanticThread(std::unique_ptr<Segmenter> segmenter, SemanticMode mode, double realtime_max_rate_hz)
    : segmenter_(std::move(segmenter)), mode_(mode), realtime_max_rate_hz_(realtime_max_rate_hz) {
  if (!segmenter_) throw std::invalid_argument("SemanticThread needs a segmenter (got nullptr)");
  worker_ = std::thread([this] { run(); });
}

SemanticThread::~SemanticThread() { stop(); }

void SemanticThread::submit(std::uint64_t frame_id, std::shared_ptr<const cv::Mat> bgr,
                            std::string frame_name) {
  if (!bgr) {
    throw InputError("semantic thread: frame " + frame_name + " was submitted without an image");
  }
  std::unique_lock lock(mutex_);
  if (mode_ == SemanticMode::kOffline) {
    space_available_.wait(lock, [&] { return stopping_ || pending_.size() < kInputCapacity; });
  }
  if (stopping_) return;
  if (any_submitted_ && frame_id <= last_submitted_id_) {
    throw InputError("semantic thread: frame id " + std::to_string(frame_id) +
                     " submitted after frame id " + std::to_string(last_submitted_id_) +
                     "; frame ids must increase");
  }
  if (mode_ == SemanticMode::kRealtime) {
    // Whatever still waits is stale now; the network should see the newest frame.
    for (const Job& stale : pending_) in_flight_.erase(stale.frame_id);
    dropped_ += pending_.size();
    pending_.clear();
  }
  const auto now = std::chrono::steady_clock::now();
  if (any_submitted_) {
    const double interval_s = std::chrono::duration<double>(now - last_submit_time_).count();
    submit_interval_s_ = submit_interval_s_ <= 0 ? interval_s : 0.9 * submit_interval_s_ + 0.1 * interval_s;
  }
  last_submit_time_ = now;
  any_submitted_ = true;
  last_submitted_id_ = frame_id;
  in_flight_.insert(frame_id);
  pending_.push_back(Job{frame_id, std::move(bgr), std::move(frame_name), now});
  job_available_.notify_one();
  // Wakes waitFor() callers: on a frame just dropped (returns nullptr), or on this one.
  result_ready_.notify_all();
}

std::shared_ptr<const Segmentation> SemanticThread::waitFor(std::uint64_t frame_id) {
  std::unique_lock lock(mutex_);
  // A frame not submitted yet is waited for; one submitted but neither in flight nor finished
  // was dropped or already erased.
  result_ready_.wait(lock, [&] {
    const bool submitted = any_submitted_ && frame_id <= last_submitted_id_;
    return stopping_ || finished_.count(frame_id) > 0 ||
           (submitted && in_flight_.count(frame_id) == 0);
  });
  const auto it = finished_.find(frame_id);
  if (it == finished_.end()) return nullptr;
  Finished found = std::move(it->second);
  finished_.erase(finished_.begin(), std::next(it));  // consumed, and older ones never will be
  lock.unlock();
  if (found.error) std::rethrow_exception(found.error);
  return found.result;
}

bool SemanticThread::waitUntilFinished(std::uint64_t frame_id, std::chrono::steady_clock::duration timeout) {
  std::unique_lock lock(mutex_);
  return result_ready_.wait_for(lock, timeout, [&] {
    return stopping_ || finished_.count(frame_id) > 0 || in_flight_.count(frame_id) == 0 || resting_;
  }) && finished_.count(frame_id) > 0;
}

std::shared_ptr<const Segmentation> SemanticThread::latest(std::uint64_t frame_id,
                                                           std::uint64_t* result_frame_id) {
  std::unique_lock lock(mutex_);
  auto it = finished_.upper_bound(frame_id);
  if (it == finished_.begin()) return nullptr;
  --it;
  // Errors come first: a failing segmenter must not be hidden behind a later good frame.
  for (auto e = finished_.begin(); e != std::next(it); ++e) {
    if (e->second.error) {
      const std::exception_ptr error = e->second.error;
      finished_.erase(finished_.begin(), std::next(e));
      lock.unlock();
      std::rethrow_exception(error);
    }
  }
  // Keep the one handed out (it stays the newest <= a later request until a newer one finishes).
  finished_.erase(finished_.begin(), it);
  if (result_frame_id != nullptr) *result_frame_id = it->first;
  return it->second.result;
}

void SemanticThread::requestOwnMask(std::uint64_t frame_id, std::shared_ptr<const cv::Mat> bgr,
                                     std::string frame_name) {
  if (!bgr) throw InputError("semantic thread: frame " + frame_name + " was requested without an image");
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    ++own_mask_requests_;
    if (const auto done = finished_.find(frame_id); done != finished_.end()) {
      own_mask_results_[frame_id] = done->second;
      return;
    }
    own_mask_wanted_.insert(frame_id);
    // Still waiting in the stream, where a newer frame would drop it: it moves to the priority queue.
    const auto waiting = std::find_if(pending_.begin(), pending_.end(), [&](const Job& j) { return j.frame_id == frame_id; });
    if (waiting != pending_.end()) {
      priority_jobs_.push_back(std::move(*waiting));
      pending_.erase(waiting);
    } else if (in_flight_.count(frame_id) == 0) {
      // Dropped (or never submitted): segmented for the request alone.
      in_flight_.insert(frame_id);
      priority_jobs_.push_back(Job{frame_id, std::move(bgr), std::move(frame_name)});
      ++own_mask_segmentations_;
    }  // else: the worker is on it now; its result is kept when it finishes
  }
  job_available_.notify_all();
}

std::shared_ptr<const Segmentation> SemanticThread::waitForOwnMask(std::uint64_t frame_id) {
  std::unique_lock lock(mutex_);
  if (own_mask_wanted_.count(frame_id) == 0 && own_mask_results_.count(frame_id) == 0) return nullptr;
  result_ready_.wait(lock, [&] { return stopping_ || own_mask_results_.count(frame_id) > 0; });
  const auto it = own_mask_results_.find(frame_id);
  if (it == own_mask_results_.end()) return nullptr;
  Finished found = std::move(it->second);
  own_mask_results_.erase(it);
  lock.unlock();
  if (found.error) std::rethrow_exception(found.error);
  return found.result;
}

std::size_t SemanticThread::ownMaskRequestCount() const {
  std::lock_guard lock(mutex_);
  return own_mask_requests_;
}

std::size_t SemanticThread::ownMaskSegmentationCount() const {
  std::lock_guard lock(mutex_);
  return own_mask_segmentations_;
}

void SemanticThread::stop() {
  {
    std::lock_guard lock(mutex_);
    if (!stopping_) {
      stopping_ = true;
      dropped_ += pending_.size() + priority_jobs_.size();
      for (const Job& job : pending_) in_flight_.erase(job.frame_id);
      for (const Job& job : priority_jobs_) in_flight_.erase(job.frame_id);
      pending_.clear();
      priority_jobs_.clear();
      own_mask_wanted_.clear();
    }
  }
  job_available_.notify_all();
  space_available_.notify_all();
  result_ready_.notify_all();
  // join() from two threads at once is a data race; stop() may come from several.
  std::lock_guard join_lock(join_mutex_);
  if (worker_.joinable()) worker_.join();
}

std::size_t SemanticThread::segmentedCount() const {
  std::lock_guard lock(mutex_);
  return segmented_;
}

std::size_t SemanticThread::droppedCount() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}

std::size_t SemanticThread::storedResultCount() const {
  std::lock_guard lock(mutex_);
  return finished_.size();
}

void SemanticThread::run() {
  // Real time: tracking waits for the network only briefly (a frame ends at most half a frame
  // period late), so the network yields the CPU to it.
  if (mode_ == SemanticMode::kRealtime) lowerCurrentThreadPriority(5);
  for (;;) {
    Job job;
    {
      std::unique_lock lock(mutex_);
      const bool rate_limited = mode_ == SemanticMode::kRealtime && realtime_max_rate_hz_ > 0;
      // A frame that waited through a rest was most likely tracked already with an older mask:
      // the next one, segmented as it arrives, can still be waited for (see the header).
      // Measured from the end of the rest, not from now: however late the worker wakes (a busy
      // CPU), a frame submitted after the rest is never stale.
      const auto stale = [&](const Job& j) {
        return rate_limited && submit_interval_s_ > 0 &&
               std::chrono::duration<double>(rest_ended_ - j.submitted).count() > 0.25 * submit_interval_s_;
      };
      for (;;) {
        job_available_.wait(lock, [&] { return stopping_ || !pending_.empty() || !priority_jobs_.empty(); });
        if (stopping_) return;
        if (!priority_jobs_.empty() || !stale(pending_.front())) break;
        for (const Job& j : pending_) in_flight_.erase(j.frame_id);
        dropped_ += pending_.size();
        pending_.clear();
        result_ready_.notify_all();
      }
      std::deque<Job>& queue = priority_jobs_.empty() ? pending_ : priority_jobs_;
      job = std::move(queue.front());
      queue.pop_front();
    }
    space_available_.notify_one();

    const auto started = std::chrono::steady_clock::now();
    Finished done;
    try {
      done.result =
          std::make_shared<const Segmentation>(segmenter_->segment(*job.bgr, job.frame_name));
    } catch (...) {
      done.error = std::current_exception();  // handed to the consumer of this frame
    }

    {
      std::lock_guard lock(mutex_);
      in_flight_.erase(job.frame_id);
      if (done.result) ++segmented_;
      if (own_mask_wanted_.erase(job.frame_id) > 0) own_mask_results_[job.frame_id] = done;
      finished_[job.frame_id] = std::move(done);
      if (mode_ == SemanticMode::kRealtime) {
        while (finished_.size() > kMaxRealtimeResults) finished_.erase(finished_.begin());
      }
    }
    result_ready_.notify_all();

    if (mode_ == SemanticMode::kRealtime && realtime_max_rate_hz_ > 0) {
      // Rate limit: rest until the next start is due (stop() still wakes the worker at once).
      const auto next = started + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(1.0 / realtime_max_rate_hz_));
      std::unique_lock lock(mutex_);
      resting_ = true;
      result_ready_.notify_all();  // a frame waited for will not start before the rest is over
      // An own-mask request does not wait for the rest (local mapping or tracking waits for it).
      job_available_.wait_until(lock, next, [&] { return stopping_ || !priority_jobs_.empty(); });
      resting_ = false;
      rest_ended_ = std::chrono::steady_clock::now();
    }
  }
}

}  // namespace desslam::semantic
