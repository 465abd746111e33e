// Bundle adjustment on the shared Map: builds the bundleAdjust problem from a set of
// keyframes and writes the result back. Local BA (local_mapper) and global BA (the final one
// after a run, and loop closing) differ only in which keyframes they pass and which are fixed.
//
// Locking: buildMapBaProblem reads the map and must be called with map.mutex() held (shared is
// enough); applyMapBaResult changes it and must be called with map.mutex() held exclusively;
// the solve in between runs without the lock, so tracking is never blocked by it.
#pragma once

#include <atomic>
#include <vector>

#include "core/camera.hpp"
#include "map/map.hpp"
#include "optim/bundle_adjustment.hpp"

namespace desslam::optim {

struct MapBaProblem {
  std::vector<map::Keyframe*> keyframes;  // same order as ba_keyframes
  std::vector<map::MapPoint*> points;     // same order as ba_points
  std::vector<BaKeyframe> ba_keyframes;
  std::vector<BaPoint> ba_points;
  std::vector<BaObservation> ba_observations;
};

// keyframes[i] is held constant when fixed[i]. The points are those seen by the free keyframes;
// each contributes its observations in every keyframe of the list (fixed ones anchor it).
// Bad keyframes and points are skipped.
MapBaProblem buildMapBaProblem(const std::vector<map::Keyframe*>& keyframes, const std::vector<bool>& fixed);

// Observations the solve flagged as outliers are erased from the map; free keyframes take their
// new poses and points their new positions (normal and depth range refreshed). Keyframes or
// points that went bad while the solve ran are left alone.
void applyMapBaResult(map::Map& map, const MapBaProblem& problem);

struct GlobalBaResult {
  size_t keyframes = 0, points = 0, observations = 0, outliers = 0;
  bool completed = false;  // false: aborted (the estimate reached so far was still applied)
  double seconds = 0;
};

// Every keyframe and point of the map; the origins and the held keyframes are fixed
// (map::globalBaFixed). Takes the map lock shared to copy the problem out and exclusively to write
// it back; solves unlocked.
GlobalBaResult globalBundleAdjustment(map::Map& map, const PinholeCamera& camera,
                                      const BundleAdjustmentOptions& options,
                                      const std::atomic<bool>* abort = nullptr);

}  // namespace desslam::optim
