// Lets another stage (loop closing, map merging) stop local mapping between keyframes.
#pragma once

#include <atomic>
#include <condition_variable>
#include <mutex>

namespace desslam::mapping {

// Lets the loop closer stop local mapping between keyframes. The local-mapping thread brackets
// each keyframe with enter()/leave(); pause() returns once no keyframe is being processed and
// keeps enter() waiting until resume(). Pauses nest (a counter). Thread-safe (own mutex).
class MappingPause {
 public:
  // -- local-mapping side --
  void enter();  // blocks while paused
  void leave();
  // Set to true by pause() (e.g. LocalMappingThread's abort_ba_, so a running local BA yields).
  void setAbortFlag(std::atomic<bool>* flag);

  // -- loop-closing side --
  void pause();   // blocks until local mapping is between keyframes
  void resume();
  bool paused() const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  int pausers_ = 0;
  bool working_ = false;
  std::atomic<bool>* abort_flag_ = nullptr;
};

}  // namespace desslam::mapping
