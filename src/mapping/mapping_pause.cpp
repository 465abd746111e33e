#include "mapping/mapping_pause.hpp"

namespace desslam::mapping {

void MappingPause::enter() {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [&] { return pausers_ == 0; });
  working_ = true;
}

void MappingPause::leave() {
  {
    std::lock_guard lock(mutex_);
    working_ = false;
  }
  cv_.notify_all();
}

void MappingPause::setAbortFlag(std::atomic<bool>* flag) {
  std::lock_guard lock(mutex_);
  abort_flag_ = flag;
}

void MappingPause::pause() {
  std::unique_lock lock(mutex_);
  ++pausers_;
  if (abort_flag_ != nullptr) *abort_flag_ = true;
  cv_.wait(lock, [&] { return !working_; });
}

void MappingPause::resume() {
  {
    std::lock_guard lock(mutex_);
    if (pausers_ > 0) --pausers_;
  }
  cv_.notify_all();
}

bool MappingPause::paused() const {
  std::lock_guard lock(mutex_);
  return pausers_ > 0;
}

}  // namespace desslam::mapping
