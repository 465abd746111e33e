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
  std::vector<Vec3> centres_before;       // each keyframe's camera centre when the problem was built
};

// Farthest bundle adjustment may move a keyframe made at a weak pose (Keyframe::made_at_weak_pose:
// few local-map inliers within 3 cm of the motion prediction). Moved further, its own new points,
// not the map, placed it: local BA carried one 21 cm on an fr1_xyz composite, and a global BA after
// a merge elsewhere carried one 16 cm on a fr1_desk composite, the frames tracked from it with it.
constexpr double kMaxWeakKeyframeMoveM = 0.05;

// Farthest local bundle adjustment may move any other keyframe: 3 m/s (tracking.max_speed_m_s)
// over one frame at 30 Hz, a step between consecutive frames that tracking itself refuses. Local
// BA's window keeps the map around it fixed: on 18 fr1 runs (10 composites with DeepLab masks, 6
// with 5-frame-old masks, the 2 static sequences) it moved keyframes not made at a weak pose more
// than 3 cm 10 times: 3.4-7.1 cm in five; 27.6 cm in a three-keyframe map in a crowd (fr1_desk
// composite), from where 42 inliers had put it, and a later global BA carried it 54 cm further,
// with the frames tracked from it (that map's ATE 0.42 m); in two other runs it slid two keyframes
// together 9.6-17.6 cm from tracked poses that were right.
constexpr double kMaxKeyframeMoveM = 0.10;

// keyframes[i] is held constant when fixed[i]. The points are those seen by the free keyframes;
// each contributes its observations in every keyframe of the list (fixed ones anchor it).
// Bad keyframes and points are skipped.
MapBaProblem buildMapBaProblem(const std::vector<map::Keyframe*>& keyframes, const std::vector<bool>& fixed);

// Observations the solve flagged as outliers are erased from the map; free keyframes take their
// new poses and points their new positions (normal and depth range refreshed). Keyframes or
// points that went bad while the solve ran are left alone.
void applyMapBaResult(map::Map& map, const MapBaProblem& problem);

// The free keyframes made at a weak pose, not held, that the solved `problem` moves more than
// max_move_m from problem.centres_before: by their own move (local BA, whose window keeps the map
// around it fixed) or, with `relative_to_parent`, by their move less their spanning-tree parent's
// where the parent is in the problem (global BA, which may shift whole stretches of a map).
// Map lock held (shared is enough).
std::vector<map::Keyframe*> weakKeyframesMovedFar(const MapBaProblem& problem, double max_move_m,
                                                  bool relative_to_parent);

// The free keyframes not made at a weak pose (those have their own bar), not held, that the solved
// `problem` moves more than max_move_m both by their own move and by their move less their
// spanning-tree parent's where the parent is in the problem: a parent and child moved together is
// a correction of both, and a child left where it was while its parent moved was not moved at all.
// For local BA. Map lock held (shared is enough).
std::vector<map::Keyframe*> keyframesMovedFar(const MapBaProblem& problem, double max_move_m);

// Fewest distinct points that tie a group of keyframes to the rest of its map for global BA to
// place the group by them. A group whose keyframes share fewer points in all with the keyframes
// outside it (the first keyframes of a map merged into another, linked to its later ones by 5
// points on a fr1_desk composite with frames dropped) holds no gauge of its own: global BA moves
// it as a whole wherever those few points pull it (34.5 cm there, where the merge had placed it
// within 6 cm). 20 is the bar a loop or merge fit needs in RANSAC inliers (loop.min_rigid_inliers).
constexpr int kMinGroupTiePoints = 20;

// The groups of free keyframes (joined by at least kMinGroupTiePoints shared points, through
// Keyframe::connection_weights) that came into their map by a merge (every keyframe made in
// another map), hold no fixed keyframe, are tied to the keyframes outside them by fewer than
// kMinGroupTiePoints distinct points, and that the solved `problem` moves more than max_move_m
// relative to the keyframes those points tie them to (or at all, with none): for each, its oldest
// keyframe. A map's own keyframes are left to global BA, which corrects their drift. Map lock
// held (shared is enough).
std::vector<map::Keyframe*> looseGroupsMovedFar(const MapBaProblem& problem, double max_move_m);

// The global problem: every keyframe and point of the map; the origins and the held keyframes are
// fixed (map::globalBaFixed). A keyframe made at a weak pose that the solve moves more than
// kMaxWeakKeyframeMoveM relative to its parent, and the oldest keyframe of a loosely tied group the
// solve moves that far (looseGroupsMovedFar), are held where they are (Keyframe::pose_held) and the
// problem is built and solved once more with them fixed. Takes the map lock shared to copy the
// problem out (exclusively to hold keyframes); solves unlocked; the caller applies the result.
struct GlobalBaSolve {
  MapBaProblem problem;
  bool solved = false;    // false: fewer than two keyframes or no point, nothing to apply
  bool finished = false;  // the last solve ran to the end (not aborted)
  size_t weak_keyframes_held = 0;
  size_t loose_groups_held = 0;
};
GlobalBaSolve solveGlobalBa(map::Map& map, const PinholeCamera& camera, const BundleAdjustmentOptions& options,
                            const std::atomic<bool>* abort = nullptr);

struct GlobalBaResult {
  size_t keyframes = 0, points = 0, observations = 0, outliers = 0;
  bool completed = false;  // false: aborted (the estimate reached so far was still applied)
  size_t weak_keyframes_held = 0;  // see solveGlobalBa
  size_t loose_groups_held = 0;    // see solveGlobalBa
  double seconds = 0;
};

// solveGlobalBa, then applyMapBaResult under the exclusive map lock.
GlobalBaResult globalBundleAdjustment(map::Map& map, const PinholeCamera& camera,
                                      const BundleAdjustmentOptions& options,
                                      const std::atomic<bool>* abort = nullptr);

}  // namespace desslam::optim
