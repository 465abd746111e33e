#include "io/frame_prefetcher.hpp"

#include <stdexcept>
#include <string>
#include <utility>

namespace desslam::io {

FramePrefetcher::FramePrefetcher(const RgbdSequence& sequence, const CameraOptions& camera,
                                 std::vector<std::size_t> indices, std::size_t max_ahead)
    : sequence_(sequence), camera_(camera), indices_(std::move(indices)), max_ahead_(max_ahead) {
  if (max_ahead_ == 0) throw std::invalid_argument("FramePrefetcher: max_ahead must be at least 1");
  thread_ = std::thread([this] { run(); });
}

FramePrefetcher::~FramePrefetcher() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  space_changed_.notify_all();
  thread_.join();
}

void FramePrefetcher::run() {
  for (std::size_t k = 0; k < indices_.size(); ++k) {
    {
      std::unique_lock lock(mutex_);
      space_changed_.wait(lock, [&] { return stopping_ || loaded_.size() < max_ahead_; });
      if (stopping_) break;
    }
    Slot slot;
    slot.index = indices_[k];
    try {
      slot.image = sequence_.load(slot.index, camera_);
    } catch (...) {
      slot.error = std::current_exception();
    }
    const bool failed = slot.error != nullptr;
    {
      std::lock_guard lock(mutex_);
      loaded_.push_back(std::move(slot));
    }
    loaded_changed_.notify_all();
    if (failed) break;  // the consumer stops at this frame
  }
  {
    std::lock_guard lock(mutex_);
    loader_done_ = true;
  }
  loaded_changed_.notify_all();
}

RgbdImage FramePrefetcher::take(std::size_t index) {
  std::unique_lock lock(mutex_);
  if (next_taken_ >= indices_.size() || indices_[next_taken_] != index)
    throw std::logic_error("FramePrefetcher::take(" + std::to_string(index) + "): the next frame to load is " +
                           (next_taken_ < indices_.size() ? std::to_string(indices_[next_taken_]) : "none"));
  loaded_changed_.wait(lock, [&] { return !loaded_.empty() || loader_done_; });
  if (loaded_.empty())
    throw std::logic_error("FramePrefetcher::take(" + std::to_string(index) + "): nothing more was loaded");
  Slot slot = std::move(loaded_.front());
  loaded_.pop_front();
  ++next_taken_;
  lock.unlock();
  space_changed_.notify_all();
  if (slot.error) std::rethrow_exception(slot.error);
  return std::move(slot.image);
}

}  // namespace desslam::io
