// Tracking: estimates the pose of every frame against the map, decides keyframes and creates
// them (with their depth-backed map points). Runs on the caller's thread.
//
// Per frame: constant-velocity prediction with guided matching by projection of the previous
// frame's points -> fallback: descriptor matching against the reference keyframe -> local-map
// tracking (points of co-visible keyframes) -> pose-only optimisation -> keyframe decision.
#pragma once

#include <cstdint>
#include <deque>
#include <initializer_list>
#include <optional>
#include <vector>

#include "core/camera.hpp"
#include "core/trajectory.hpp"
#include "map/frame.hpp"
#include "map/map.hpp"
#include "matching/matcher.hpp"
#include "tracking/depth_alignment.hpp"
#include "tracking/relocaliser.hpp"
#include "tracking/tracking_options.hpp"

namespace desslam::tracking {

enum class TrackingState { kNotInitialized, kOk, kLost };

// Where a frame's pose came from. Tracked and backfilled poses are measured (the frame's own
// features against the map); the others are guesses from the motion around the frame.
enum class PoseSource : uint8_t {
  kNone,                // no pose
  kTracked,             // tracked (a map's first frame too)
  kBackfilled,          // tracked backwards from a frame found again (tracking.backfill_max_s)
  kPredicted,           // the motion before a loss, extrapolated (tracking.predict_through_loss_s)
  kPredictedBackwards,  // the motion after a loss, extrapolated backwards (tracking.predict_back_s)
  kInterpolated,        // between two poses around it
};

// What the trajectory needs of each frame: its pose relative to its reference keyframe, so that
// the final trajectory follows the keyframes' optimised poses.
struct FrameRecord {
  uint64_t frame_id = 0;
  Timestamp timestamp = 0;
  const map::Keyframe* reference = nullptr;  // null when the frame was not tracked
  SE3 T_c_r;
  int map_id = -1;  // the atlas map it was tracked in (-1: none); merges may have moved it since
  PoseSource source = PoseSource::kNone;

  bool measured() const { return source == PoseSource::kTracked || source == PoseSource::kBackfilled; }
};

// Two measured records (indices into a run's records) whose guessed frames between them are to be
// interpolated between the two.
struct MeasuredPair {
  size_t before = 0;
  size_t after = 0;
};

// Rule 1 of Tracker::interpolateAcrossMerges, on the records alone: pairs of measured records in
// the same map now (map_now[k]: the map records[k]'s reference keyframe is in now, -1 without one),
// at most max_span_s apart, with at least one guess (kNone, kPredicted, kPredictedBackwards)
// between them and nothing else between them but guesses and frames measured in another map. Such
// a frame is a map started in the loss and lost again, never merged: its pose is in that map's
// world and says nothing of this one's, so it keeps its pose and does not leave the guesses around
// it to the prediction of one side (a fr1_xyz composite: a one-frame map in a 0.4 s loss left nine
// predicted frames up to 16 cm off and a 22 cm step to the next map's first frame).
std::vector<MeasuredPair> guessesBetweenMeasuredPoses(const std::vector<FrameRecord>& records,
                                                      const std::vector<int>& map_now, double max_span_s);

// The camera, tracked in a map started at a loss, found in another map of the atlas too
// (atlas.other_map_search_s): what loop closing needs to merge the two, at the keyframe made there.
struct FoundInOtherMap {
  map::Keyframe* keyframe = nullptr;         // made at this frame, in the map tracking works in
  map::Keyframe* other_reference = nullptr;  // the other map's keyframe sharing most points with the frame
  SE3 T_wother_c;                            // the frame's (and keyframe's) pose in the other map's world
  std::vector<map::MapPoint*> other_points;  // per feature: the other map's point it matched (inliers), or null
  int inliers = 0;                           // of the pose in the other map
};

struct TrackOutcome {
  bool tracked = false;
  int stage1_checked = 0;   // features examined by stage 1 (in the mask, or all in geometric mode)
  int stage1_removed = 0;   // found dynamic by stage 1 (in the mask, plus the free-space test outside it)
  int free_space_removed = 0;  // of those, by the free-space test outside the mask
  int map_verified = 0;        // of those, taken back: a map point at their depth vouched for them
  int stage2_removed = 0;   // found dynamic by stage 2 (their map points culled)
  map::Keyframe* new_keyframe = nullptr;  // to hand to local mapping
  int inliers = 0;                        // map-point inliers after local-map tracking
  bool used_motion_model = false;
  bool new_map = false;                   // this frame started a map of the atlas
  bool weak = false;                      // tracked with few inliers that agreed with the motion prediction
  bool predicted = false;                 // not tracked, but given the motion prediction as its pose
  bool odometry = false;                  // the map gave no pose; frame-to-frame odometry did (counts as tracked)
  bool depth_odometry = false;            // ... depth alignment to the last frame did (tracking.depth_odometry_max_s)
  // Earlier frames (lost, or predicted) whose records were replaced now: tracked backwards from
  // this frame (tracking.backfill_max_s), or interpolated between the last frame tracked before
  // the loss and them (found again in the same map).
  std::vector<uint64_t> backfilled;
  std::vector<uint64_t> interpolated;
  // Earlier frames of a loss given the motion after it, extrapolated backwards
  // (tracking.predict_back_s), in map predicted_backwards_map.
  std::vector<uint64_t> predicted_backwards;
  int predicted_backwards_map = -1;
  std::optional<RelocalisationResult> relocalisation;  // when the relocaliser was asked
  std::optional<FoundInOtherMap> found_in_other_map;   // for loop closing to merge the maps
};

class Tracker {
 public:
  // database (may be null: no relocalisation): the keyframe BoW database local mapping keeps.
  Tracker(const TrackerOptions& options, const PinholeCamera& camera, map::Map& map,
          const place::KeyframeDatabase* database = nullptr);

  // frame.features and frame.status are set; writes frame.T_c_w and frame.matches.
  // mapping_idle: local mapping has no keyframe waiting (a keyframe criterion). mapping_backlog:
  // keyframes queued or in work there; from kMaxMappingBacklog on, no keyframe is made while
  // tracking holds (real time: a queue that only grows would block tracking).
  static constexpr int kMaxMappingBacklog = 2;
  TrackOutcome track(map::Frame& frame, bool mapping_idle, int mapping_backlog = 0);

  TrackingState state() const { return state_; }
  const std::vector<FrameRecord>& records() const { return records_; }
  int lostFrames() const { return lost_frames_; }
  int losses() const { return losses_; }                    // times tracking went from ok to lost
  int relocalisations() const { return relocalisations_; }  // times the relocaliser recovered it
  int foundInOtherMap() const { return found_in_other_map_; }  // atlas.other_map_search_s: merges handed on
  int implausibleJumps() const { return implausible_jumps_; }  // poses refused by tracking.max_speed_m_s
  // Poses found again after a bridged loss, refused by tracking.max_acceleration_m_s2.
  int bridgeDisagreements() const { return bridge_disagreements_; }
  // ... and those accepted there because they had far more inliers than the frames the bridge rests on.
  int bridgeOverruled() const { return bridge_overruled_; }
  int weakPoses() const { return weak_poses_; }  // frames kept with few inliers near the prediction
  int predictedPoses() const { return predicted_poses_; }  // lost frames given the motion prediction
  // Of those, the ones whose motion since the predicted frame before came from odometry against it.
  int predictedByOdometry() const { return predicted_by_odometry_; }
  int backfilledPoses() const { return backfilled_poses_; }  // frames tracked backwards afterwards
  int odometryPoses() const { return odometry_poses_; }  // frames whose pose came from odometry alone
  int depthOdometryPoses() const { return depth_odometry_poses_; }  // of those, from depth alignment
  int interpolatedPoses() const { return interpolated_poses_; }  // frames interpolated afterwards
  int backwardPredictedPoses() const { return backward_predicted_poses_; }  // tracking.predict_back_s
  // The end of a run: frames still waiting for the motion after their loss
  // (tracking.predict_back_s) get the motion of the frames tracked since, when at least two were.
  void finishBackwardPrediction(TrackOutcome& outcome);
  // The end of a run, all merges done (no frame is being tracked). Online, settle() can interpolate
  // only when the camera is found again in the map it was lost in; now:
  //  1. frames with a predicted pose (or none) between two measured ones that ended in the same
  //     map, at most tracking.interpolate_predictions_within_s apart with no other frame measured
  //     in that map between them, get poses interpolated between those two; frames measured in
  //     another map between them keep theirs (guessesBetweenMeasuredPoses);
  //  2. frames still without a pose between two frames with one (any kind) that ended in the same
  //     map, at most twice tracking.backfill_max_s apart, get poses interpolated between those two;
  //     frames tracked in another map between them (one started in the loss and lost again) keep
  //     theirs.
  // Returns their new records.
  std::vector<FrameRecord> interpolateAcrossMerges();
  // The end of a run, after interpolateAcrossMerges(): frames still without a pose get the pose of
  // the nearer frame with one (tracking.hold_pose_s; every such frame between two with one under
  // tracking.hold_pose_between_poses). Returns their new records (source kPredicted when that frame
  // is before them, kPredictedBackwards when after).
  std::vector<FrameRecord> holdNearestPoses();
  int heldPoses() const { return held_poses_; }  // frames given the nearer pose (tracking.hold_pose_s)
  int mapsStarted() const { return maps_started_; }           // maps of the atlas this tracker started
  int initialisationsRefused() const { return initialisations_refused_; }  // frames too weak to start a map
  int activeMap() const { return active_map_; }               // -1 before the first map

  // Whether `frame` could start a map: atlas.min_initial_features static depth-backed features
  // over at least atlas.min_initial_cells cells of a 4 x 4 grid.
  static bool canStartMap(const map::Frame& frame, const PinholeCamera& camera, const AtlasOptions& options);
  struct MapStartSupport {
    int features_with_depth = 0;  // usable (static) features with depth
    int cells = 0;                // cells of the 4 x 4 grid holding at least 5 of them
  };
  static MapStartSupport mapStartSupport(const map::Frame& frame, const PinholeCamera& camera);

 private:
  // Starts a map of the atlas at `frame` (reason for the map's record) when it is strong enough.
  bool initialize(map::Frame& frame, TrackOutcome& outcome, const char* reason);
  // Lost: whether relocalisation had its time (or the map is too young to wait for) and a new map
  // should start at this frame.
  bool shouldStartNewMap(const map::Frame& frame, bool young_map) const;
  // Before a new map starts shortly after a loss (atlas.start_free_space_check_s): static features
  // the last map's reference keyframe saw through, at the bridged pose, become dynamic (see there).
  void dropWhatTheLastMapSawThrough(map::Frame& frame, TrackOutcome& outcome);
  // Forgets the motion and local map of the map tracking left (a new one starts).
  void resetForNewMap();
  // Within atlas.other_map_search_s of a map started at a loss, for a frame tracked in it: the frame
  // relocalised against the other maps and tracked in the local map of the one it was found in
  // (with stage 2). Its pose there and matched points once that sighting agrees with an earlier
  // one (kMapTransformAgreement*), keyframe still null; the tracker's own state is left as it was.
  std::optional<FoundInOtherMap> findInOtherMap(const map::Frame& frame);
  // The first sighting of the current window that later ones are compared with.
  struct OtherMapSighting {
    Timestamp timestamp = 0;
    int map_id = -1;
    SE3 T_wother_wactive;
  };
  std::optional<OtherMapSighting> first_sighting_;
  bool trackWithMotionModel(map::Frame& frame);
  // Projection candidates from a tracked frame: its matched map points and, for close features
  // without one, visual-odometry points from its depth.
  std::vector<matching::ProjectionCandidate> motionCandidates(const map::Frame& from) const;
  // Guided search of `candidates` from predicted_T_c_w, the window scaled by each `widen` factor
  // in turn until kMinMotionMatches matched, then pose-only optimisation when at least
  // min_matches did (inliers 0 otherwise).
  struct SearchResult {
    int matches = 0;
    int inliers = 0;
  };
  SearchResult searchFromPrediction(map::Frame& frame, const std::vector<matching::ProjectionCandidate>& candidates,
                                    const SE3& predicted_T_c_w, std::initializer_list<double> widen, int min_matches);
  // A frame with no pose or a predicted one: kept (features only) for settle().
  void keepUnsettled(const map::Frame& frame, bool predicted);
  // `found` was just tracked: the frames kept by keepUnsettled() get poses, newest first, each
  // tracked backwards from the one after it, until one fails (tracking.backfill_max_s); the rest
  // that lie after before_loss (the last tracked frame, given when `found` is in its map) are
  // interpolated between it and the oldest one settled. Clears them.
  void settle(const map::Frame& found, const std::optional<StampedPose>& before_loss, TrackOutcome& outcome);
  // Frames since the last tracked one (oldest first, unsettled_): without a pose, or with a
  // predicted one (then the map it was predicted in).
  struct UnsettledFrame {
    map::Frame frame;
    bool predicted = false;
    int map_id = -1;
  };
  // Frames settle() left without a pose, just before the oldest frame it gave one (the anchor),
  // waiting for the motion of the frames tracked after the anchor (tracking.predict_back_s).
  struct BackwardPrediction {
    std::vector<UnsettledFrame> frames;  // newest first
    uint64_t anchor_frame_id = 0;
  };
  std::optional<BackwardPrediction> backward_prediction_;
  // Gives backward_prediction_'s frames their poses: the motion from the anchor over the
  // kBridgeVelocityFrames frames tracked after it, extrapolated back from the anchor's pose. Waits
  // for those frames until the track ends (lost again, or the run is over): then at least two
  // frames after the anchor must have been tracked. With fewer (a map that lived a frame or two
  // between two losses) the frames go back to unsettled_, for the next frame tracked (in this map
  // or the next one) to settle with the frames lost since.
  enum class TrackEnd { kNotYet, kLost, kRunOver };
  void predictBackwards(TrackOutcome& outcome, TrackEnd end);
  bool trackReferenceKeyframe(map::Frame& frame);
  // Frame-to-frame odometry against last_frame (last_frame_, or the predicted frame before this one)
  // (tracking.odometry_min_inliers): descriptor matches of the frame's static features with the
  // last frame's depth-backed ones, then PnP-RANSAC. Nothing when too few inliers or the camera
  // would have moved implausibly fast.
  struct OdometryPose {
    SE3 T_c_w;
    std::vector<map::FeatureMatch> matches;  // the inliers: map points, else visual-odometry points
    int inliers = 0;
  };
  std::optional<OdometryPose> trackWithOdometry(const map::Frame& frame, const map::Frame& last_frame) const;
  // tracking.depth_odometry_max_s: the frame's pose from its depth aligned to last_frame_'s, from
  // the prediction; nothing when the alignment is refused (DepthAlignmentResult::accepted).
  std::optional<SE3> trackWithDepth(const map::Frame& frame, const SE3& predicted_T_c_w);
  // The camera motion T_later_earlier over `seconds` at the current velocity (identity without one).
  SE3 motionOver(double seconds) const;
  // Whether pose T_c_w at time t implies a camera faster than tracking.max_speed_m_s since the last
  // tracked frame.
  bool implausibleJump(const SE3& T_c_w, Timestamp t) const;
  // Descriptor matching against one keyframe's map points, then pose-only optimisation.
  bool trackKeyframe(map::Frame& frame, map::Keyframe* keyframe);
  // When lost: the newest keyframes, one after another (relocalisation light).
  bool trackRecentKeyframes(map::Frame& frame);
  bool trackLocalMap(map::Frame& frame, int& inliers);
  // Second local-map search: the candidates no static feature took, among the masked features
  // stage 1 could not check (Frame::map_verifiable), at the point's depth (dynamic.stage1_map_check).
  // Caller holds the map lock (shared).
  void verifyMaskedFeaturesByMap(map::Frame& frame, const std::vector<matching::ProjectionCandidate>& candidates);
  // Stage 1: features in the mask (all features in geometric mode) whose depth disagrees with
  // the previous frame's, given the pose estimated without them, become dynamic.
  void applyStage1(map::Frame& frame, TrackOutcome& outcome);
  // The newest tracked frame at least dynamic.stage1_min_interval_s older than `frame`.
  const map::Frame& stage1Reference(const map::Frame& frame) const;
  // Stage 2: matched map points whose depth disagrees with co-visible keyframes' observed depth
  // are residual dynamics: the feature leaves the pose estimate, the point is culled.
  // Returns the number removed.
  int applyStage2(map::Frame& frame);
  // Pose-only optimisation on the frame's matches; drops outliers. Returns map-point inliers.
  int optimizeFramePose(map::Frame& frame);
  void updateLocalMap(const map::Frame& frame);
  bool needKeyframe(const map::Frame& frame, int inliers, bool mapping_idle, int mapping_backlog) const;
  // Null when the mask leaves the frame too little to map (see kMinKeyframeObservations). hold_pose:
  // see Keyframe::pose_held; weak_pose: Keyframe::made_at_weak_pose.
  map::Keyframe* createKeyframe(map::Frame& frame, int inliers, bool hold_pose = false, bool weak_pose = false);
  // The feature status a keyframe of `frame` maps with (nothing within the mapping margin of the
  // mask); nothing when that leaves too little (fewer points accepted when tracking starves).
  std::optional<std::vector<map::FeatureStatus>> mappableStatus(const map::Frame& frame, int inliers) const;
  cv::Mat halfDepthFor(const map::Frame& frame) const;
  void createDepthPoints(map::Frame& frame, const std::vector<map::FeatureStatus>& status, map::Keyframe* kf);  // exclusive lock held

  TrackerOptions options_;
  PinholeCamera camera_;
  map::Map& map_;
  double bf_;
  MatcherOptions matcher_options_;
  bool stage1_enabled_ = false;  // dynamic.mode full or geometric
  bool stage2_enabled_ = false;

  TrackingState state_ = TrackingState::kNotInitialized;
  map::Frame last_frame_;
  const map::Keyframe* last_reference_ = nullptr;  // last_frame_'s reference keyframe
  SE3 last_T_c_r_;
  std::optional<SE3> velocity_;  // T_current_last of the previous step
  double velocity_interval_s_ = 0;  // the time that step took
  // The last tracked frames' poses (oldest first): the motion bridged through a loss is their
  // average over kBridgeVelocityFrames, not the last step's, which walkers crossing the view just
  // before the loss disturb most. Each pose follows its reference keyframe (as history_ does):
  // a merge or loop correction between two of them would otherwise count as camera motion. They
  // are all in the map tracked now: a frame found again after a loss and a map's start begin anew.
  struct RecentPose {
    Timestamp timestamp = 0;
    const map::Keyframe* reference = nullptr;
    SE3 T_c_r;
    SE3 T_c_w;
    int inliers = 0;  // local-map inliers (odometry's for an odometry pose; a map's first frame: its points)
  };
  std::deque<RecentPose> recent_poses_;
  // The constant velocity over recent_poses_[0..last], as the motion from recent_poses_[last]'s time
  // to t; none from fewer than two poses or no time between them.
  std::optional<SE3> recentMotion(size_t last, Timestamp t) const;
  SE3 bridgedPose(Timestamp t) const;
  // tracking.max_acceleration_m_s2: refused when the frame's pose is too far from bridgedPose() and
  // its local-map inliers (0 for an odometry pose) do not outweigh those of the bridge's frames
  // (tracking.bridge_overruled_inlier_ratio); overruled when they do.
  enum class BridgeJudgement { kAgrees, kRefused, kOverruled };
  BridgeJudgement judgeAgainstBridge(const map::Frame& frame, int map_inliers) const;
  map::Keyframe* reference_keyframe_ = nullptr;
  map::Keyframe* last_keyframe_ = nullptr;
  uint64_t last_keyframe_frame_id_ = 0;
  std::vector<map::Keyframe*> local_keyframes_;
  std::vector<map::MapPoint*> local_points_;
  std::vector<uint64_t> point_stamp_;  // per point id: frame id it was last added to the local map
  // Recent tracked frames, newest last (stage-1 references). Their poses are stored relative to
  // their reference keyframe and refreshed before use, so they follow BA, loops and merges.
  struct HistoryFrame {
    map::Frame frame;
    const map::Keyframe* reference = nullptr;
    SE3 T_c_r;
  };
  std::deque<HistoryFrame> history_;
  std::deque<UnsettledFrame> unsettled_;
  void pushHistory(const map::Frame& frame, const map::Keyframe* reference, const SE3& T_c_r);
  std::vector<FrameRecord> records_;
  int lost_frames_ = 0;
  int losses_ = 0;
  int relocalisations_ = 0;
  int found_in_other_map_ = 0;
  int implausible_jumps_ = 0;
  int bridge_disagreements_ = 0;
  int bridge_overruled_ = 0;
  int maps_started_ = 0;
  int weak_poses_ = 0;
  int predicted_poses_ = 0;
  int predicted_by_odometry_ = 0;
  int backfilled_poses_ = 0;
  int odometry_poses_ = 0;
  int depth_odometry_poses_ = 0;
  int interpolated_poses_ = 0;
  int backward_predicted_poses_ = 0;
  int held_poses_ = 0;
  int initialisations_refused_ = 0;
  int active_map_ = -1;         // the atlas map tracking works in (its live id after merges)
  Timestamp lost_since_ = 0;    // timestamp of the first lost frame of the current loss
  Timestamp search_other_maps_until_ = 0;  // findInOtherMap() is tried up to this time
  std::optional<Timestamp> odometry_only_since_;  // first frame of the current run of odometry-only poses
  std::optional<DepthAligner> depth_aligner_;     // tracking.depth_odometry_max_s > 0
  // last_frame_'s depth prepared for alignment, when it was (the frame aligned last becomes the
  // next one's reference).
  std::optional<std::pair<uint64_t, DepthPyramid>> last_depth_pyramid_;
  std::optional<Timestamp> depth_only_since_;     // first frame of the current run of depth-odometry poses
  std::optional<map::Frame> last_predicted_;      // the previous frame, when it got a predicted pose
  std::optional<Relocaliser> relocaliser_;
};

}  // namespace desslam::tracking
