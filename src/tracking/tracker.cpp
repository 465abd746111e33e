#include "tracking/tracker.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <mutex>
#include <random>
#include <shared_mutex>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

#include "dynamic/depth_checks.hpp"
#include "dynamic/mask_utils.hpp"
#include "tracking/frame_pose.hpp"

namespace desslam::tracking {

namespace {
constexpr int kMinMotionMatches = 20;      // below: widen the window once, then give up
constexpr int kMinMapInliersStep = 10;     // after motion-model / reference-keyframe tracking
constexpr int kMinLocalMapInliers = 30;    // after local-map tracking
constexpr int kMinLocalMapInliersAfterStage2 = 20;
constexpr int kMinWeakInliers = 12;           // with a pose that agrees with the motion prediction
constexpr double kWeakMaxDeviationM = 0.03;   // ... within this distance and angle of it
constexpr double kWeakMaxDeviationRad = 2.0 * M_PI / 180;
constexpr double kMotionRadius = 7.0;      // pixels at level 0, frame-to-frame window
constexpr double kLocalMapRadius = 3.0;    // RGB-D local-map window factor
constexpr int kCloseTrackedNeeded = 100;   // "need close points" keyframe criterion
constexpr int kCloseUntrackedEnough = 70;
constexpr int kMinNewDepthPoints = 100;    // a keyframe gets at least this many depth points
constexpr int kMinKeyframeObservations = 100;  // mappable features a keyframe needs beside a mask
constexpr int kMinKeyframeObservationsStarving = 50;  // ... when tracking is about to be lost
constexpr int kStarvingInliers = kMinLocalMapInliers + 10;  // local-map inliers below which it is
constexpr size_t kRecoveryKeyframes = 8;   // when lost, the newest keyframes tried before giving up
constexpr double kStillTranslation = 0.005;        // metres per frame below which motion is negligible
constexpr double kStillRotation = 0.5 * M_PI / 180;  // radians per frame
constexpr size_t kBridgeVelocityFrames = 5;  // tracked frames whose average motion bridges a loss
// findInOtherMap: per frame, the largest other maps searched (a merge needs two sightings that
// agree: map/atlas_options.hpp, mapTransformsAgree).
constexpr size_t kOtherMapsSearched = 3;
// Frame-to-frame odometry (trackWithOdometry): descriptor matching between consecutive frames,
// whose descriptors barely change, within a window around the same pixel.
constexpr int kOdometryMaxDescriptorDistance = 64;
constexpr double kOdometryMatchRatio = 0.8;
constexpr double kOdometryWindowPx = 100.0;     // per 1/30 s since the last tracked frame ...
constexpr double kOdometryMaxWindowPx = 300.0;  // ... up to this
constexpr double kOdometryDepthTolerance = 0.1;  // relative depth disagreement an odometry inlier may have
constexpr int kMinOdometryKeyframeMapPoints = 20;  // map points below which an odometry keyframe's pose is held
// Keyframes keep a half-resolution depth image only when stage 2 will look at it.

bool nearPrediction(const SE3& T_c_w, const SE3& predicted_T_c_w, double max_deviation_m = kWeakMaxDeviationM) {
  const SE3 difference = T_c_w * predicted_T_c_w.inverse();
  return (T_c_w.inverse().translation() - predicted_T_c_w.inverse().translation()).norm() <= max_deviation_m &&
         difference.rotationAngle() <= kWeakMaxDeviationRad;
}

// How far from the bridged (or predicted) pose a pose found `seconds` after the last tracked frame
// may lie (tracking.max_acceleration_m_s2 = a): 3 cm + a t^2 / 2, at least one frame's worth of t.
double bridgeBoundM(double a, double seconds) {
  const double t = std::max(seconds, 1.0 / 30.0);
  return kWeakMaxDeviationM + 0.5 * a * t * t;
}

// Without a tracked frame just before this one, stage 1 cannot vouch for masked features: they
// stay out of the pose and the map.
void keepUnverifiedMaskedFeaturesOut(map::Frame& frame) {
  for (auto& status : frame.status)
    if (status == map::FeatureStatus::kPendingStage1) status = map::FeatureStatus::kDynamicMask;
}

// 1 for each feature within the frame's mapping margin of its (dilated) person mask, where keyframes
// map nothing; all 0 without a mask.
std::vector<uint8_t> featuresNearPeople(const map::Frame& frame) {
  if (frame.dynamic_mask.empty()) return std::vector<uint8_t>(frame.features->size(), 0);
  return dynamic::featuresInMask(*frame.features, frame.mapping_margin_px > 0
                                                      ? dynamic::dilateMask(frame.dynamic_mask, frame.mapping_margin_px)
                                                      : frame.dynamic_mask);
}

// Odometry inliers (a map point or a visual-odometry point) whose feature lies outside the person
// mask grown by the mapping margin: static points away from every detected person that agree with
// the frame's pose. A walker's limbs that the network misses lie next to its mask, within the margin.
int odometryInliersClearOfMask(const map::Frame& frame) {
  const std::vector<uint8_t> near_person = featuresNearPeople(frame);
  int clear = 0;
  for (size_t i = 0; i < frame.matches.size(); ++i) {
    const map::FeatureMatch& m = frame.matches[i];
    clear += !near_person[i] && (m.point != nullptr || m.has_vo_point) && !m.outlier;
  }
  return clear;
}

// Share of the frame's features inside its person mask (0 without a mask).
double maskedShare(const map::Frame& frame) {
  if (frame.dynamic_mask.empty() || frame.features->size() == 0) return 0.0;
  const std::vector<uint8_t> in_mask = dynamic::featuresInMask(*frame.features, frame.dynamic_mask);
  return static_cast<double>(std::count(in_mask.begin(), in_mask.end(), uint8_t{1})) / static_cast<double>(in_mask.size());
}

// The middle value (the two middle ones averaged for an even count); 0 for none.
double medianOf(std::vector<int> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t half = values.size() / 2;
  return values.size() % 2 == 1 ? values[half] : 0.5 * (values[half - 1] + values[half]);
}
}  // namespace

Tracker::Tracker(const TrackerOptions& options, const PinholeCamera& camera, map::Map& map,
                 const place::KeyframeDatabase* database)
    : options_(options), camera_(camera), map_(map), bf_(camera.bf()) {
  if (database != nullptr && options.relocalisation.enabled)
    relocaliser_.emplace(options.relocalisation, camera_, map_, *database, bf_);
  matcher_options_ = options.matching;
  stage1_enabled_ = stage2_enabled_ = usesDepthChecks(options.dynamic.mode);
  if (options.tracking.depth_odometry_max_s > 0) {
    DepthAlignmentOptions depth;
    depth.min_depth_m = options.tracking.min_depth;
    depth.max_depth_m = options.tracking.max_depth;
    depth_aligner_.emplace(camera_, depth);
  }
}

TrackOutcome Tracker::track(map::Frame& frame, bool mapping_idle, int mapping_backlog) {
  TrackOutcome outcome;
  // A map merge moves whole maps: it waits until this frame is done (Map::worldGate()).
  std::shared_lock world(map_.worldGate());
  if (state_ == TrackingState::kNotInitialized) {
    initialize(frame, outcome, "first");
    return outcome;
  }

  // The previous frames' poses follow their reference keyframes, which local BA, loop closing and
  // map merges may have moved.
  {
    std::shared_lock lock(map_.mutex());
    if (last_reference_ != nullptr) last_frame_.T_c_w = last_T_c_r_ * map::keyframeTcw(last_reference_);
    for (HistoryFrame& h : history_)
      if (h.reference != nullptr) h.frame.T_c_w = h.T_c_r * map::keyframeTcw(h.reference);
    for (RecentPose& r : recent_poses_)
      if (r.reference != nullptr) r.T_c_w = r.T_c_r * map::keyframeTcw(r.reference);
    if (reference_keyframe_ != nullptr) active_map_ = reference_keyframe_->map_id;
  }

  if (options_.tracking.compensate_depth_delay && velocity_ && std::abs(frame.depth_time_offset) > 1e-4) {
    // Constant velocity: the camera at the depth image's time, seen from the RGB image's time.
    const SE3 T_rgb_depth = motionOver(-frame.depth_time_offset);
    frame.features = map::compensateDepthDelay(*frame.features, camera_, frame.depth, T_rgb_depth,
                                               options_.tracking.min_depth, options_.tracking.max_depth);
  }

  // The frame before this one when it was given a predicted pose (see the loss below).
  std::optional<map::Frame> previous_predicted;
  previous_predicted.swap(last_predicted_);
  bool ok = false;
  // Just lost (a crowd covered the view for a moment): the motion before the loss still predicts
  // where to look, for tracking.predict_through_loss_s after the last tracked frame.
  const bool recently_lost = state_ == TrackingState::kLost &&
                             frame.timestamp - last_frame_.timestamp <= options_.tracking.predict_through_loss_s;
  if (state_ == TrackingState::kLost && !recently_lost) velocity_.reset();
  const bool had_motion = (state_ == TrackingState::kOk || recently_lost) && velocity_.has_value();
  const SE3 predicted_T_c_w = motionOver(frame.timestamp - last_frame_.timestamp) * last_frame_.T_c_w;
  if (had_motion) {
    ok = trackWithMotionModel(frame);
    outcome.used_motion_model = ok;
  }
  const char* first_estimate = ok ? "motion model" : nullptr;  // where the pose came from (debug log)
  if (!ok) {
    ok = trackReferenceKeyframe(frame);
    if (ok) first_estimate = "reference keyframe";
  }
  const bool recovering = state_ == TrackingState::kLost;
  if (!ok && recovering) {
    // The place may be anywhere in the map: ask the BoW database; the newest keyframes remain a
    // fallback (and the only way without a database).
    if (relocaliser_) {
      const RelocalisationResult r = relocaliser_->relocalise(frame);
      outcome.relocalisation = r;
      if (r.success) {
        ok = true;
        first_estimate = "relocalisation";
        reference_keyframe_ = r.keyframe;
        ++relocalisations_;
      }
    }
    // relocalisation.enabled = false turns every way back into an old map off (the atlas then
    // starts a new map).
    if (!ok && options_.relocalisation.enabled) {
      ok = trackRecentKeyframes(frame);
      if (ok) first_estimate = "recent keyframes";
    }
  }
  // No pose from the map: frame-to-frame odometry needs no prediction. A camera turning fast while
  // walkers cover most of the view outruns the motion model's window and leaves the reference
  // keyframe too few points, yet hundreds of static features still match the last frame's.
  std::optional<OdometryPose> odometry;
  if (!ok && options_.tracking.odometry_min_inliers > 0) {
    odometry = trackWithOdometry(frame, last_frame_);
    if (odometry) {
      frame.T_c_w = odometry->T_c_w;
      frame.matches = odometry->matches;
      ok = true;
      first_estimate = "odometry";
    }
  }
  // Nor from the features at all (people covering the texture, motion blur): the depth image
  // still shows walls, floor and furniture. Only while tracking holds, for a limited run: its
  // frame-to-frame drift goes uncorrected until the map is found again.
  std::optional<SE3> depth_pose;
  if (!ok && !odometry && !recovering && had_motion && depth_aligner_ &&
      (!depth_only_since_ || frame.timestamp - *depth_only_since_ <= options_.tracking.depth_odometry_max_s)) {
    depth_pose = trackWithDepth(frame, predicted_T_c_w);
    if (depth_pose) {
      frame.clearMatches();
      frame.T_c_w = *depth_pose;
      ok = true;
      first_estimate = "depth odometry";
    }
  }
  // Too few features outside the mask for a first estimate (a person filling the view): fall
  // back on the motion prediction and let stage 1 and the local map decide. Only then: without
  // masked features a failed first estimate means the prediction is not to be trusted.
  const bool masked_features_pending =
      std::count(frame.status.begin(), frame.status.end(), map::FeatureStatus::kPendingStage1) > 0;
  const bool use_prediction = !ok && had_motion && masked_features_pending;
  // Lost beyond the prediction: the local map around the last tracked pose (frame.T_c_w below).
  const bool search_last_pose = !ok && recovering && !had_motion && reference_keyframe_ != nullptr &&
                                options_.tracking.search_last_pose_when_lost;
  if (!ok) {
    frame.clearMatches();
    frame.T_c_w = velocity_ ? motionOver(frame.timestamp - last_frame_.timestamp) * last_frame_.T_c_w : last_frame_.T_c_w;
  }
  if (recovering)
    keepUnverifiedMaskedFeaturesOut(frame);  // as for the first frame
  else if (stage1_enabled_)
    applyStage1(frame, outcome);
  int inliers = 0;
  const bool attempted = ok || use_prediction || search_last_pose;
  if (attempted) ok = trackLocalMap(frame, inliers);
  outcome.map_verified = static_cast<int>(
      std::count(frame.map_verifiable.begin(), frame.map_verifiable.end(), map::kMapVerified));
  // People covering most of the view may leave fewer static inliers than the usual bar. Such a
  // pose is kept when it agrees with the motion prediction: losing the track would cost far more
  // than a pose held by few points and the camera's own motion (counted as weak). After a loss the
  // prediction has run on for several frames: a pose with the bar after stage 2 is kept within the
  // bound the bridge gate allows a pose found again (3 cm + a t^2 / 2 since the last tracked frame,
  // tracking.max_acceleration_m_s2; Bonn crowd frame 717, 3 frames after the last tracked one: 25
  // inliers 3.9 cm from the prediction, 1.5 cm from the truth where the interpolated pose was 2.7).
  const auto weakButConsistent = [&] {
    if (!had_motion) return false;
    if (inliers >= kMinWeakInliers && nearPrediction(frame.T_c_w, predicted_T_c_w)) return true;
    const double a = options_.tracking.max_acceleration_m_s2;
    if (!recovering || a <= 0 || inliers < kMinLocalMapInliersAfterStage2) return false;
    return nearPrediction(frame.T_c_w, predicted_T_c_w, bridgeBoundM(a, frame.timestamp - last_frame_.timestamp));
  };
  bool weak = false;
  if (attempted && !ok && weakButConsistent()) ok = weak = true;
  // should_log: the odometry part is formatted before spdlog could drop the line.
  if (weak && spdlog::should_log(spdlog::level::debug))
    spdlog::debug("tracking: frame {} weak pose: {} inliers, {:.3f} m from the prediction{}", frame.id, inliers,
                  (frame.T_c_w.inverse().translation() - predicted_T_c_w.inverse().translation()).norm(),
                  odometry ? fmt::format(", {:.3f} m from the odometry pose ({} inliers)",
                                         (frame.T_c_w.inverse().translation() -
                                          odometry->T_c_w.inverse().translation()).norm(),
                                         odometry->inliers)
                           : std::string());
  if (attempted && !ok && had_motion)
    spdlog::debug("tracking: frame {} local map: {} inliers, {:.3f} m and {:.2f} deg from the prediction", frame.id,
                  inliers, (frame.T_c_w.inverse().translation() - predicted_T_c_w.inverse().translation()).norm(),
                  (frame.T_c_w * predicted_T_c_w.inverse()).rotationAngle() * 180.0 / M_PI);
  // The local map has too few points here (the view is new, or covered where it is mapped): the
  // odometry pose stands; the next frame goes on from it (a keyframe only in a young map: see the
  // keyframe decision below).
  bool odometry_only = false;
  if (!ok && odometry) {
    spdlog::debug("tracking: frame {} keeps its odometry pose: the local map gave {} inliers", frame.id, inliers);
    frame.T_c_w = odometry->T_c_w;
    frame.matches = odometry->matches;
    inliers = odometry->inliers;
    ok = odometry_only = true;
  }
  bool depth_only = false;
  if (!ok && depth_pose) {
    spdlog::debug("tracking: frame {} keeps its depth-odometry pose: the local map gave {} inliers", frame.id,
                  inliers);
    frame.T_c_w = *depth_pose;
    frame.clearMatches();
    inliers = 0;
    ok = odometry_only = depth_only = true;
  }
  if (ok && stage2_enabled_ && !odometry_only) {
    outcome.stage2_removed = applyStage2(frame);
    if (outcome.stage2_removed > 0) inliers = optimizeFramePose(frame);
    ok = inliers >= kMinLocalMapInliersAfterStage2 || (weak = weakButConsistent());
  }
  if (ok && weak) ++weak_poses_;
  outcome.weak = ok && weak;
  outcome.inliers = inliers;
  // Back in the map of the last tracked frame (relocalised, or found near the last pose): the
  // camera cannot have gone further than the time since allows either. A crowd's features, mapped
  // where the masks missed them, make a consistent but wrong consensus (a 128-inlier relocalisation
  // 2 m away, 0.17 s after the last tracked frame, on a crowded fr1_desk composite).
  bool back_in_last_map = false;
  if (ok && recovering && last_reference_ != nullptr && reference_keyframe_ != nullptr) {
    std::shared_lock lock(map_.mutex());
    back_in_last_map = last_reference_->map_id == reference_keyframe_->map_id;
  }
  if (ok && (!recovering || back_in_last_map) && implausibleJump(frame.T_c_w, frame.timestamp)) {
    ok = false;
    ++implausible_jumps_;
  }
  // Found again in the same map after a bridged loss: unmasked features on people are not checked
  // by stage 1 while recovering, and may carry the pose along with them (a fr1_xyz composite with
  // close walkers: 8 cm off the bridged pose 2 frames after the loss, then 3.5 cm more per frame).
  // Only the local map's support can outweigh the bridge's: an odometry pose rests on one frame.
  if (ok && recovering && back_in_last_map && had_motion) {
    const BridgeJudgement judgement = judgeAgainstBridge(frame, odometry_only ? 0 : inliers);
    if (judgement == BridgeJudgement::kRefused) {
      ok = false;
      ++bridge_disagreements_;
    } else if (judgement == BridgeJudgement::kOverruled) {
      ++bridge_overruled_;
    }
  }

  outcome.odometry = ok && odometry_only;
  outcome.depth_odometry = ok && depth_only;
  if (outcome.odometry) ++odometry_poses_;
  if (outcome.depth_odometry) ++depth_odometry_poses_;
  if (!outcome.depth_odometry) depth_only_since_.reset();
  else if (!depth_only_since_) depth_only_since_ = frame.timestamp;
  if (!ok) {
    // The run of frames tracked after an earlier loss ends here: their motion is all there is.
    predictBackwards(outcome, TrackEnd::kLost);
    if (state_ == TrackingState::kOk) {
      ++losses_;
      lost_since_ = frame.timestamp;
    }
    state_ = TrackingState::kLost;
    odometry_only_since_.reset();
    // The velocity stays for tracking.predict_through_loss_s (see above); stage 1 must not compare with frames
    // from before the gap.
    history_.clear();
    bool young = false;
    {
      std::shared_lock lock(map_.mutex());
      young = map_.keyframeCount(active_map_) < static_cast<size_t>(options_.atlas.young_map_keyframes);
    }
    // A short loss (people passing close, a hand over the lens) is bridged by the motion
    // prediction; a new map only starts when that is over (or the map is too young to wait for).
    const bool predict = had_motion && reference_keyframe_ != nullptr &&
                         frame.timestamp - last_frame_.timestamp <= options_.tracking.predict_through_loss_s;
    if ((!predict || young) && shouldStartNewMap(frame, young)) {
      dropWhatTheLastMapSawThrough(frame, outcome);
      // A start that will be refused (a covered camera) must not cost the bridge its velocity.
      if (!predict || canStartMap(frame, camera_, options_.atlas)) resetForNewMap();
      if (initialize(frame, outcome, young ? "young map lost" : "lost")) return outcome;
    }
    if (predict) {
      frame.clearMatches();
      frame.T_c_w = bridgedPose(frame.timestamp);
      // After the first predicted frame: the motion since the one before, measured by
      // frame-to-frame odometry against it where it can be, else the bridge's own step; the
      // bridge from the last tracked frame is what this frame's search and gates still use. A
      // sweep that speeds up or turns as the loss begins leaves the constant velocity behind (an
      // fr1_desk composite: 19 cm off after 10 frames, while odometry between consecutive frames
      // found 68-100 inliers each). A step faster than tracking.max_speed_m_s came from a wrong
      // consensus (a 25 cm jump in one frame on another): the bridge's step then.
      if (previous_predicted && previous_predicted->id + 1 == frame.id) {
        const SE3 bridge_step = frame.T_c_w * bridgedPose(previous_predicted->timestamp).inverse();
        frame.T_c_w = bridge_step * previous_predicted->T_c_w;
        const std::optional<OdometryPose> step = options_.tracking.odometry_min_inliers > 0
                                                     ? trackWithOdometry(frame, *previous_predicted)
                                                     : std::nullopt;
        const double step_s = std::max(frame.timestamp - previous_predicted->timestamp, 1.0 / 30.0);
        const Vec3 previous_centre = previous_predicted->T_c_w.inverse().translation();
        if (step && (step->T_c_w.inverse().translation() - previous_centre).norm() <=
                        options_.tracking.max_speed_m_s * step_s) {
          frame.T_c_w = step->T_c_w;
          ++predicted_by_odometry_;
        }
      }
      frame.has_pose = true;
      SE3 T_c_r;
      {
        std::shared_lock lock(map_.mutex());
        T_c_r = frame.T_c_w * map::keyframeTcw(reference_keyframe_).inverse();
      }
      records_.push_back({frame.id, frame.timestamp, reference_keyframe_, T_c_r, active_map_, PoseSource::kPredicted});
      ++predicted_poses_;
      outcome.predicted = true;
      keepUnsettled(frame, /*predicted=*/true);
      last_predicted_ = frame;
      last_predicted_->depth = cv::Mat();  // the features hold their depth; the image may be the caller's buffer
      last_predicted_->dynamic_mask = cv::Mat();
      return outcome;
    }
    ++lost_frames_;
    records_.push_back({frame.id, frame.timestamp, nullptr, SE3(), -1});
    keepUnsettled(frame, /*predicted=*/false);
    return outcome;
  }

  if (recovering)
    spdlog::debug("tracking: frame {} tracked again after {:.3f} s, {} inliers ({}{})", frame.id,
                  frame.timestamp - last_frame_.timestamp, inliers,
                  first_estimate != nullptr ? first_estimate
                  : search_last_pose       ? "local map around the last pose"
                                           : "motion prediction",
                  back_in_last_map ? ", same map" : "");
  state_ = TrackingState::kOk;
  frame.has_pose = true;
  outcome.tracked = true;
  // Back after a loss: the motion across the gap still estimates the velocity when the gap was
  // short and the camera is back in the same map; otherwise the last tracked frame says nothing.
  bool velocity_across_gap = false;
  if (recovering && !outcome.used_motion_model && last_reference_ != nullptr &&
      frame.timestamp - last_frame_.timestamp <= options_.tracking.predict_through_loss_s) {
    std::shared_lock lock(map_.mutex());
    velocity_across_gap = last_reference_->map_id == reference_keyframe_->map_id;
  }
  if (recovering && !outcome.used_motion_model && !velocity_across_gap) {
    velocity_.reset();  // the last tracked frame lies before the gap
  } else {
    velocity_ = frame.T_c_w * last_frame_.T_c_w.inverse();
    velocity_interval_s_ = frame.timestamp - last_frame_.timestamp;
  }
  // Tracking continues in the map the pose came from: relocalisation may have found the camera in
  // another map of the atlas, and the keyframe decision below (and the keyframe) belong to that map.
  // (Before, a keyframe made at such a frame joined the lost map with a pose in the other map's
  // world: a 1.6 m jump inside one map on an fr1_desk composite.)
  {
    std::shared_lock lock(map_.mutex());
    active_map_ = reference_keyframe_->map_id;
  }
  // A keyframe at an odometry pose in a young map (atlas.young_map_keyframes), where the
  // alternative is a map that never grows: tracking left its only keyframe behind (a fr1_desk
  // composite: 110 frames tracked by odometry alone, 100-390 inliers each, in a map of one keyframe
  // that place recognition could never find). In a grown map the next frames usually find the map;
  // there a keyframe at an odometry pose that a walker's coherent motion had carried (22 cm off
  // with 107 inliers) corrupted it. Sharing few map points, bundle adjustment could move it
  // anywhere (8 cm on another composite): its pose is then held (Keyframe::pose_held).
  // A grown map left behind (odometry alone for tracking.odometry_keyframe_after_s) grows again
  // from a view the mask shows nearly free of people.
  if (!outcome.odometry) odometry_only_since_.reset();
  else if (!odometry_only_since_) odometry_only_since_ = frame.timestamp;
  bool may_make_keyframe = true, hold_pose = false;
  if (outcome.depth_odometry) {
    may_make_keyframe = false;  // no feature of it was matched: nothing to map from
  } else if (outcome.odometry) {
    const double after_s = options_.tracking.odometry_keyframe_after_s;
    const bool left_behind = after_s > 0 && frame.timestamp - *odometry_only_since_ >= after_s &&
                             (maskedShare(frame) <= options_.tracking.odometry_keyframe_max_masked_share ||
                              (options_.tracking.odometry_keyframe_min_clear_inliers > 0 &&
                               odometryInliersClearOfMask(frame) >= options_.tracking.odometry_keyframe_min_clear_inliers));
    std::shared_lock lock(map_.mutex());
    may_make_keyframe =
        left_behind || map_.keyframeCount(active_map_) < static_cast<size_t>(options_.atlas.young_map_keyframes);
    if (may_make_keyframe) {
      const auto shared = std::count_if(frame.matches.begin(), frame.matches.end(), [](const map::FeatureMatch& m) {
        return m.point != nullptr && !m.point->bad && !m.outlier;
      });
      hold_pose = shared < kMinOdometryKeyframeMapPoints;
    }
  }
  // Shortly after a map started at a loss, the camera may still be where another map is (a crowd
  // covered the view for a moment): a keyframe here then carries what loop closing needs to merge
  // the two. Place recognition alone rarely merges such a map: it must recognise two of its
  // keyframes in a row, and one started in a crowd sees little of the static scene.
  std::optional<FoundInOtherMap> other;
  if (!outcome.weak && !outcome.odometry) other = findInOtherMap(frame);
  if (may_make_keyframe && (other || needKeyframe(frame, inliers, mapping_idle, mapping_backlog)))
    outcome.new_keyframe = createKeyframe(frame, inliers, hold_pose, outcome.weak);
  if (other && outcome.new_keyframe != nullptr) {
    spdlog::debug("tracking: frame {} (keyframe {}, map {}) found in map {} with {} inliers: handed on for merging",
                  frame.id, outcome.new_keyframe->id, active_map_, other->other_reference->map_id, other->inliers);
    other->keyframe = outcome.new_keyframe;
    outcome.found_in_other_map = std::move(other);
    ++found_in_other_map_;
    search_other_maps_until_ = 0;
    first_sighting_.reset();
  }

  {
    std::shared_lock lock(map_.mutex());
    last_T_c_r_ = frame.T_c_w * reference_keyframe_->T_c_w.inverse();
  }
  last_reference_ = reference_keyframe_;
  records_.push_back({frame.id, frame.timestamp, reference_keyframe_, last_T_c_r_, active_map_, PoseSource::kTracked});
  if (!recent_poses_.empty() && recent_poses_.back().timestamp >= frame.timestamp) recent_poses_.clear();
  if (recovering) recent_poses_.clear();  // the frames before the gap may be in another map
  recent_poses_.push_back({frame.timestamp, reference_keyframe_, last_T_c_r_, frame.T_c_w, inliers});
  while (recent_poses_.size() > kBridgeVelocityFrames + 1) recent_poses_.pop_front();
  // The frames between the last tracked frame and this one (lost, or predicted) get poses.
  if (!unsettled_.empty()) {
    std::optional<StampedPose> before_loss;
    if (recovering && back_in_last_map) before_loss = StampedPose{last_frame_.timestamp, last_frame_.T_c_w.inverse()};
    settle(frame, before_loss, outcome);
  }
  predictBackwards(outcome, TrackEnd::kNotYet);
  // Visual-odometry matches only serve the next frame's motion-model search.
  last_frame_ = frame;
  pushHistory(frame, reference_keyframe_, last_T_c_r_);
  return outcome;
}

void Tracker::keepUnsettled(const map::Frame& frame, bool predicted) {
  const double keep_s = std::max(options_.tracking.backfill_max_s, options_.tracking.predict_back_s);
  if (keep_s <= 0) return;
  UnsettledFrame kept{frame, predicted, predicted ? active_map_ : -1};
  kept.frame.depth = cv::Mat();  // the features hold their depth; the image may be the caller's buffer
  kept.frame.dynamic_mask = cv::Mat();
  kept.frame.clearMatches();
  kept.frame.has_pose = false;
  const Timestamp t = kept.frame.timestamp;
  if (!unsettled_.empty() && unsettled_.back().frame.timestamp >= t) unsettled_.clear();
  unsettled_.push_back(std::move(kept));
  // Older ones cannot be reached from a frame tracked again (see settle()).
  while (unsettled_.front().frame.timestamp < t - 2 * keep_s) unsettled_.pop_front();
}

void Tracker::settle(const map::Frame& found, const std::optional<StampedPose>& before_loss, TrackOutcome& outcome) {
  if (unsettled_.empty()) return;
  std::deque<UnsettledFrame> frames;
  frames.swap(unsettled_);
  const auto setRecord = [&](uint64_t frame_id, Timestamp timestamp, const SE3& T_c_w, PoseSource source) {
    SE3 T_c_r;
    {
      std::shared_lock lock(map_.mutex());
      T_c_r = T_c_w * map::keyframeTcw(reference_keyframe_).inverse();
    }
    for (auto r = records_.rbegin(); r != records_.rend(); ++r)
      if (r->frame_id == frame_id) {
        *r = {frame_id, timestamp, reference_keyframe_, T_c_r, active_map_, source};
        break;
      }
  };
  const double max_s = options_.tracking.backfill_max_s;
  map::Frame next = found;  // the frame after the one tracked next, with its pose and matches
  // The motion backwards: the velocity the found frame was tracked with, then the chain's own.
  std::optional<SE3> T_earlier_later;
  double step_s = 0;
  if (velocity_ && velocity_interval_s_ > 1e-6) {
    T_earlier_later = velocity_->inverse();
    step_s = velocity_interval_s_;
  }
  // 1. Backwards from the found frame, one frame after another, while each is tracked. A frame
  // predicted in another map than the found one's stays there (its map may never be merged).
  auto it = frames.rbegin();
  for (; it != frames.rend(); ++it) {
    if (it->predicted && it->map_id != active_map_) break;
    map::Frame& frame = it->frame;
    if (found.timestamp - frame.timestamp > max_s || next.timestamp <= frame.timestamp) break;
    const double dt = next.timestamp - frame.timestamp;
    const SE3 predicted = T_earlier_later ? SE3::exp(T_earlier_later->log() * (dt / step_s)) * next.T_c_w : next.T_c_w;
    const auto [matches, inliers] =
        searchFromPrediction(frame, motionCandidates(next), predicted, {1.0, 2.0, 4.0}, kMinWeakInliers);
    // The bars of tracking (no local map refines the pose here): a tracked pose's after stage 2,
    // or a weak pose's, near the prediction.
    const bool accepted = inliers >= kMinLocalMapInliersAfterStage2 ||
                          (inliers >= kMinWeakInliers && nearPrediction(frame.T_c_w, predicted));
    const double moved = (frame.T_c_w.inverse().translation() - next.T_c_w.inverse().translation()).norm();
    if (!accepted || moved > options_.tracking.max_speed_m_s * std::max(dt, 1.0 / 30.0)) {
      spdlog::debug("tracking: backfill from frame {} stops at frame {}: {} matches, {} inliers", found.id, frame.id,
                    matches, inliers);
      break;
    }
    setRecord(frame.id, frame.timestamp, frame.T_c_w, PoseSource::kBackfilled);
    outcome.backfilled.push_back(frame.id);
    ++backfilled_poses_;
    T_earlier_later = frame.T_c_w * next.T_c_w.inverse();
    step_s = std::max(dt, 1e-6);
    next = std::move(frame);
  }
  // 2. Found again in the map of the last frame tracked before the loss: the frames left between
  // the two lie on the motion from one to the other, a better guess than the prediction made from
  // before the loss alone (which drifts by centimetres within 0.3 s when the camera turns).
  if (before_loss && next.timestamp - before_loss->timestamp <= 2 * max_s) {
    const SE3 T0 = before_loss->T_w_c.inverse();  // T_c_w at the last tracked frame
    const SE3 motion = next.T_c_w * T0.inverse();
    const double span = next.timestamp - before_loss->timestamp;
    for (; it != frames.rend(); ++it) {
      const map::Frame& frame = it->frame;
      if (frame.timestamp <= before_loss->timestamp || !(span > 1e-6)) break;
      if (it->predicted && it->map_id != active_map_) break;
      const double s = (frame.timestamp - before_loss->timestamp) / span;
      setRecord(frame.id, frame.timestamp, SE3::exp(motion.log() * s) * T0, PoseSource::kInterpolated);
      outcome.interpolated.push_back(frame.id);
      ++interpolated_poses_;
    }
  }
  // 3. The frames still without a pose just before the oldest one settled (no feature search
  // reached them: a crowd, motion blur, a covered lens) wait for the motion after it.
  BackwardPrediction waiting{{}, next.id};
  for (; it != frames.rend(); ++it) {
    if (it->predicted || next.timestamp - it->frame.timestamp > options_.tracking.predict_back_s) break;
    waiting.frames.push_back(std::move(*it));
  }
  if (!waiting.frames.empty()) backward_prediction_ = std::move(waiting);
  if (!outcome.backfilled.empty() || !outcome.interpolated.empty() || backward_prediction_)
    spdlog::debug("tracking: frame {} settled {} earlier frames: {} backfilled, {} interpolated, {} wait for the "
                  "motion after frame {}", found.id, frames.size(), outcome.backfilled.size(),
                  outcome.interpolated.size(), backward_prediction_ ? backward_prediction_->frames.size() : 0,
                  backward_prediction_ ? backward_prediction_->anchor_frame_id : next.id);
}

void Tracker::predictBackwards(TrackOutcome& outcome, TrackEnd end) {
  if (!backward_prediction_) return;
  // The anchor's record and those of the frames tracked right after it (records_ is in frame order).
  auto anchor = std::find_if(records_.rbegin(), records_.rend(), [&](const FrameRecord& r) {
    return r.frame_id == backward_prediction_->anchor_frame_id;
  });
  if (anchor == records_.rend()) {
    backward_prediction_.reset();
    return;
  }
  const auto first = anchor.base() - 1;
  auto last = first;
  while (last + 1 != records_.end() && last + 1 - first <= static_cast<std::ptrdiff_t>(kBridgeVelocityFrames) &&
         (last + 1)->reference != nullptr)
    ++last;
  const auto tracked_after = last - first;
  if (end == TrackEnd::kNotYet && tracked_after < static_cast<std::ptrdiff_t>(kBridgeVelocityFrames)) return;
  BackwardPrediction waiting = std::move(*backward_prediction_);
  backward_prediction_.reset();
  // One step's motion is too noisy to extrapolate over a third of a second. Lost again right
  // after the anchor, the frames wait for the next frame tracked: a map that lived a frame or two
  // between two losses (people crossing again) otherwise cost them their poses for good (a
  // fr1_desk composite with 5-frame-old masks: 7 frames between a loss and such a map).
  if (tracked_after < 2 || !(last->timestamp - first->timestamp > 1e-6)) {
    if (end == TrackEnd::kLost) {
      for (UnsettledFrame& f : waiting.frames) unsettled_.push_front(std::move(f));
      spdlog::debug("tracking: {} frames before frame {} wait for the next frame tracked ({} tracked after it)",
                    waiting.frames.size(), waiting.anchor_frame_id, tracked_after);
    }
    return;
  }
  std::shared_lock lock(map_.mutex());
  const map::Keyframe* reference = first->reference;
  const int map_id = first->map_id;  // the anchor's, as it was tracked
  const SE3 T_w_r = map::keyframeTcw(reference).inverse();
  const SE3 T0 = first->T_c_r * map::keyframeTcw(reference);
  const SE3 motion = last->T_c_r * map::keyframeTcw(last->reference) * T0.inverse();
  const double span_s = last->timestamp - first->timestamp;
  for (const UnsettledFrame& f : waiting.frames) {
    const uint64_t frame_id = f.frame.id;
    const Timestamp timestamp = f.frame.timestamp;
    auto r = std::find_if(records_.rbegin(), records_.rend(),
                          [&](const FrameRecord& record) { return record.frame_id == frame_id; });
    if (r == records_.rend() || r->reference != nullptr) continue;
    const SE3 T_c_w = SE3::exp(motion.log() * ((timestamp - first->timestamp) / span_s)) * T0;
    *r = {frame_id, timestamp, reference, T_c_w * T_w_r, map_id, PoseSource::kPredictedBackwards};
    outcome.predicted_backwards.push_back(frame_id);
    ++backward_predicted_poses_;
  }
  outcome.predicted_backwards_map = map_id;
  spdlog::debug("tracking: {} frames before frame {} predicted backwards from the motion over the {} frames after it",
                outcome.predicted_backwards.size(), waiting.anchor_frame_id, tracked_after);
}

void Tracker::finishBackwardPrediction(TrackOutcome& outcome) { predictBackwards(outcome, TrackEnd::kRunOver); }

std::vector<MeasuredPair> guessesBetweenMeasuredPoses(const std::vector<FrameRecord>& records,
                                                      const std::vector<int>& map_now, double max_span_s) {
  if (map_now.size() != records.size())
    throw std::invalid_argument("guessesBetweenMeasuredPoses: map_now needs one map id per record");
  const auto guess = [](const FrameRecord& r) {
    return r.source == PoseSource::kNone || r.source == PoseSource::kPredicted ||
           r.source == PoseSource::kPredictedBackwards;
  };
  std::vector<MeasuredPair> pairs;
  std::unordered_map<int, size_t> last_measured;  // map id now -> its last measured record so far
  for (size_t b = 0; b < records.size(); ++b) {
    if (!records[b].measured() || map_now[b] < 0) continue;
    const auto it = last_measured.find(map_now[b]);
    if (it != last_measured.end()) {
      const size_t a = it->second;
      // Between a and b (a is this map's last measured record): guesses, or frames measured in
      // another map; an interpolated frame ends it (settle() placed it between other poses).
      bool guesses_between = false, only_guesses_or_other_maps = true;
      for (size_t k = a + 1; k < b && only_guesses_or_other_maps; ++k) {
        guesses_between |= guess(records[k]);
        only_guesses_or_other_maps = guess(records[k]) || records[k].measured();
      }
      if (guesses_between && only_guesses_or_other_maps && records[b].timestamp - records[a].timestamp <= max_span_s)
        pairs.push_back({a, b});
    }
    last_measured[map_now[b]] = b;
  }
  return pairs;
}

std::vector<FrameRecord> Tracker::interpolateAcrossMerges() {
  std::vector<FrameRecord> interpolated;
  std::shared_lock lock(map_.mutex());
  // Record k (and its map) from the motion between records a and b around it.
  const auto interpolateAt = [&](const FrameRecord& a, const FrameRecord& b, size_t k) {
    const double span = b.timestamp - a.timestamp;
    if (!(span > 1e-6)) return;
    const SE3 T_a_w = a.T_c_r * map::keyframeTcw(a.reference);
    const SE3 T_b_w = b.T_c_r * map::keyframeTcw(b.reference);
    const SE3 motion = T_b_w * T_a_w.inverse();
    FrameRecord& r = records_[k];
    const double s = (r.timestamp - a.timestamp) / span;
    r.T_c_r = SE3::exp(motion.log() * s) * T_a_w * map::keyframeTcw(a.reference).inverse();
    r.reference = a.reference;
    r.map_id = a.map_id;
    r.source = PoseSource::kInterpolated;
    interpolated.push_back(r);
    ++interpolated_poses_;
  };

  // 1. Predictions between two measured poses close enough in time, in one map now (frames
  // measured in another map between them keep their poses). Interpolated frames between them
  // (settle() did, between the same two) stay as they are.
  if (options_.tracking.interpolate_predictions_within_s > 0) {
    std::vector<int> map_now(records_.size(), -1);
    for (size_t k = 0; k < records_.size(); ++k)
      if (records_[k].reference != nullptr) map_now[k] = records_[k].reference->map_id;
    for (const MeasuredPair& pair :
         guessesBetweenMeasuredPoses(records_, map_now, options_.tracking.interpolate_predictions_within_s))
      for (size_t k = pair.before + 1; k < pair.after; ++k)
        if (!records_[k].measured()) interpolateAt(records_[pair.before], records_[pair.after], k);
  }

  // 2. Frames without a pose between two with one, in one map now.
  const double max_span_s = 2 * options_.tracking.backfill_max_s;
  if (max_span_s <= 0) return interpolated;
  for (size_t i = 1; i < records_.size(); ++i) {
    // A run of frames without a pose starts at i; `before` is the frame with one before it.
    if (records_[i].reference != nullptr || records_[i - 1].reference == nullptr) continue;
    const FrameRecord& before = records_[i - 1];
    // The next frame with a pose in that map; frames tracked in another map on the way (a map
    // started in the loss and lost again, never merged) keep their poses there.
    size_t j = i + 1;
    while (j < records_.size() && records_[j].timestamp - before.timestamp <= max_span_s &&
           (records_[j].reference == nullptr || records_[j].reference->map_id != before.reference->map_id))
      ++j;
    if (j == records_.size() || records_[j].timestamp - before.timestamp > max_span_s) continue;
    for (size_t k = i; k < j; ++k)
      if (records_[k].reference == nullptr) interpolateAt(before, records_[j], k);
  }
  return interpolated;
}

std::vector<FrameRecord> Tracker::holdNearestPoses() {
  std::vector<FrameRecord> held;
  const double max_s = options_.tracking.hold_pose_s;
  if (max_s <= 0) return held;
  for (size_t i = 0; i < records_.size(); ++i) {
    if (records_[i].reference != nullptr) continue;
    // A run of frames without a pose: i .. j-1, between records i-1 and j (where those exist).
    size_t j = i;
    while (j < records_.size() && records_[j].reference == nullptr) ++j;
    // With a pose on both sides, every frame of the run gets one (tracking.hold_pose_between_poses).
    const bool between_poses = i > 0 && j < records_.size() && options_.tracking.hold_pose_between_poses;
    for (size_t k = i; k < j; ++k) {
      const Timestamp t = records_[k].timestamp;
      const double since_before_s = i > 0 ? t - records_[i - 1].timestamp : max_s + 1;
      const double until_after_s = j < records_.size() ? records_[j].timestamp - t : max_s + 1;
      const bool from_before = since_before_s <= until_after_s;
      if (!between_poses && !(std::min(since_before_s, until_after_s) <= max_s)) continue;
      const FrameRecord& nearest = records_[from_before ? i - 1 : j];
      FrameRecord& r = records_[k];
      r.reference = nearest.reference;  // the same pose relative to the same keyframe: it follows that keyframe
      r.T_c_r = nearest.T_c_r;
      r.map_id = nearest.map_id;
      r.source = from_before ? PoseSource::kPredicted : PoseSource::kPredictedBackwards;
      held.push_back(r);
      ++held_poses_;
    }
    i = j;
  }
  return held;
}

void Tracker::pushHistory(const map::Frame& frame, const map::Keyframe* reference, const SE3& T_c_r) {
  if (!stage1_enabled_) return;
  history_.push_back({frame, reference, T_c_r});
  while (history_.size() > 1 &&
         frame.timestamp - history_[1].frame.timestamp >= options_.dynamic.stage1_min_interval_s)
    history_.pop_front();
}

void Tracker::dropWhatTheLastMapSawThrough(map::Frame& frame, TrackOutcome& outcome) {
  if (!stage1_enabled_ || last_reference_ == nullptr) return;
  const double since_s = frame.timestamp - last_frame_.timestamp;
  if (!(since_s >= 0) || since_s > options_.atlas.start_free_space_check_s) return;
  std::vector<uint8_t> test(frame.status.size(), 0);
  int tested = 0;
  for (size_t i = 0; i < frame.status.size(); ++i)
    if (frame.usable(i) && frame.features->hasDepth(i)) {
      test[i] = 1;
      ++tested;
    }
  dynamic::FreeSpaceInput input;
  input.current = frame.features.get();
  input.depth_scale = 2;
  input.test = &test;
  std::vector<uint8_t> moved;
  {
    std::shared_lock lock(map_.mutex());
    if (last_reference_->bad || last_reference_->half_depth.empty()) return;
    input.reference_depth = &last_reference_->half_depth;
    input.T_ref_k = last_reference_->T_c_w * bridgedPose(frame.timestamp).inverse();
    moved = dynamic::freeSpaceViolations(input, camera_, options_.dynamic);
  }
  int removed = 0;
  for (size_t i = 0; i < moved.size(); ++i) {
    if (!moved[i]) continue;
    frame.status[i] = map::FeatureStatus::kDynamicStage1;
    ++removed;
  }
  outcome.stage1_removed += removed;
  outcome.free_space_removed += removed;
  spdlog::debug("tracking: frame {} ({:.3f} s after the last tracked frame): {} of {} static depth-backed features "
                "lie where the last map's keyframe saw farther",
                frame.id, since_s, removed, tested);
}

bool Tracker::shouldStartNewMap(const map::Frame& frame, bool young_map) const {
  if (!options_.atlas.enabled) return false;
  return young_map || frame.timestamp - lost_since_ >= options_.atlas.new_map_after_lost_s - 1e-6;
}

std::optional<FoundInOtherMap> Tracker::findInOtherMap(const map::Frame& frame) {
  if (!relocaliser_ || frame.timestamp > search_other_maps_until_) return std::nullopt;
  // Each other live map on its own, largest first: the relocaliser keeps only candidates close to
  // the best one's score, so with all maps together a map just started in the same crowd could
  // leave the map the camera is still in without a candidate.
  std::vector<std::pair<size_t, int>> maps;  // (keyframes, id)
  {
    std::shared_lock lock(map_.mutex());
    for (const map::MapRecord& m : map_.mapRecords())
      if (m.merged_into < 0 && m.id != active_map_ && map_.keyframeCount(m.id) > 0)
        maps.emplace_back(map_.keyframeCount(m.id), m.id);
  }
  std::sort(maps.begin(), maps.end(), std::greater<>());
  if (maps.size() > kOtherMapsSearched) maps.resize(kOtherMapsSearched);
  map::Frame probe = frame;
  bool relocalised = false;
  for (const auto& [keyframes, map_id] : maps) {
    const RelocalisationResult attempt = relocaliser_->relocalise(probe, map_id);
    spdlog::debug("tracking: frame {} (map {}) searched in map {}: {} candidates, best {} matches, {} PnP inliers, "
                  "{} inliers{}", frame.id, active_map_, map_id, attempt.candidates, attempt.best_matches,
                  attempt.best_pnp_inliers, attempt.best_inliers, attempt.success ? ": found" : "");
    if ((relocalised = attempt.success)) break;
  }
  if (!relocalised) return std::nullopt;
  // Relocalisation and the local-map search below use the tracker's local map: it goes back after.
  map::Keyframe* const reference_before = reference_keyframe_;
  std::vector<map::Keyframe*> local_keyframes_before = local_keyframes_;
  std::vector<map::MapPoint*> local_points_before = local_points_;
  const auto restore = [&] {
    reference_keyframe_ = reference_before;
    local_keyframes_ = std::move(local_keyframes_before);
    local_points_ = std::move(local_points_before);
  };
  reference_keyframe_ = nullptr;
  int inliers = 0;
  bool ok = trackLocalMap(probe, inliers);  // its reference keyframe: the one sharing most points
  if (ok && stage2_enabled_ && reference_keyframe_ != nullptr) {
    if (applyStage2(probe) > 0) inliers = optimizeFramePose(probe);
    ok = inliers >= kMinLocalMapInliersAfterStage2;
  }
  map::Keyframe* const other_reference = reference_keyframe_;
  restore();
  if (!ok || other_reference == nullptr) return std::nullopt;
  OtherMapSighting sighting{frame.timestamp, -1, probe.T_c_w.inverse() * frame.T_c_w};
  {
    std::shared_lock lock(map_.mutex());
    sighting.map_id = other_reference->map_id;
  }
  if (sighting.map_id == active_map_) return std::nullopt;
  spdlog::debug("tracking: frame {} (map {}) also found in map {} with {} inliers", frame.id, active_map_,
                sighting.map_id, inliers);
  if (!first_sighting_ || first_sighting_->map_id != sighting.map_id) {
    first_sighting_ = sighting;
    return std::nullopt;
  }
  if (!mapTransformsAgree(first_sighting_->T_wother_wactive, sighting.T_wother_wactive)) {
    first_sighting_ = sighting;  // the earlier one may have been the wrong one
    return std::nullopt;
  }
  if (sighting.timestamp - first_sighting_->timestamp < kMapTransformAgreementS) return std::nullopt;
  FoundInOtherMap found{nullptr, other_reference, probe.T_c_w.inverse(),
                        std::vector<map::MapPoint*>(probe.matches.size(), nullptr), inliers};
  for (size_t i = 0; i < probe.matches.size(); ++i)
    if (probe.matches[i].point != nullptr && !probe.matches[i].outlier) found.other_points[i] = probe.matches[i].point;
  return found;
}

void Tracker::resetForNewMap() {
  velocity_.reset();
  history_.clear();
  local_keyframes_.clear();
  local_points_.clear();
}

bool Tracker::canStartMap(const map::Frame& frame, const PinholeCamera& camera, const AtlasOptions& options) {
  const MapStartSupport support = mapStartSupport(frame, camera);
  return support.features_with_depth >= options.min_initial_features && support.cells >= options.min_initial_cells;
}

Tracker::MapStartSupport Tracker::mapStartSupport(const map::Frame& frame, const PinholeCamera& camera) {
  constexpr int kGrid = 4;
  constexpr int kMinPerCell = 5;  // a cell with fewer is not counted as covered
  int with_depth = 0;
  std::array<int, kGrid * kGrid> per_cell{};
  for (size_t i = 0; i < frame.features->size(); ++i) {
    if (!frame.usable(i) || !frame.features->hasDepth(i)) continue;
    ++with_depth;
    const cv::Point2f& pt = frame.features->keypoints[i].pt;
    const int cx = std::clamp(static_cast<int>(pt.x * kGrid / camera.width()), 0, kGrid - 1);
    const int cy = std::clamp(static_cast<int>(pt.y * kGrid / camera.height()), 0, kGrid - 1);
    ++per_cell[cy * kGrid + cx];
  }
  const int cells = static_cast<int>(std::count_if(per_cell.begin(), per_cell.end(), [](int n) { return n >= kMinPerCell; }));
  return {with_depth, cells};
}

bool Tracker::initialize(map::Frame& frame, TrackOutcome& outcome, const char* reason) {
  keepUnverifiedMaskedFeaturesOut(frame);
  frame.clearMatches();
  if (!canStartMap(frame, camera_, options_.atlas)) {
    // Waiting for a better frame; the caller counts a lost frame when a map had started.
    ++initialisations_refused_;
    const MapStartSupport support = mapStartSupport(frame, camera_);
    spdlog::debug("tracking: frame {} cannot start a map ({}): {} static depth-backed features over {} cells "
                  "(atlas.min_initial_features {}, min_initial_cells {})", frame.id, reason,
                  support.features_with_depth, support.cells, options_.atlas.min_initial_features,
                  options_.atlas.min_initial_cells);
    if (state_ == TrackingState::kNotInitialized) {
      records_.push_back({frame.id, frame.timestamp, nullptr, SE3(), -1});
      keepUnsettled(frame, /*predicted=*/false);
    }
    return false;
  }
  frame.T_c_w = SE3::identity();
  frame.has_pose = true;
  map::Keyframe* kf = nullptr;
  int points_created = 0;
  {
    std::unique_lock lock(map_.mutex());
    active_map_ = map_.createMap(frame.id, frame.timestamp, reason);
    kf = map_.createKeyframe(frame.id, frame.timestamp, frame.image_name, frame.features, frame.status,
                             halfDepthFor(frame), frame.T_c_w, active_map_);
    for (size_t i = 0; i < frame.features->size(); ++i) {
      if (!frame.usable(i) || !frame.features->hasDepth(i)) continue;
      map::MapPoint* p = map_.createPoint(camera_.backProject(frame.features->uv[i], frame.features->depth[i]), kf);
      map::addObservation(p, kf, static_cast<int>(i));
      map::updateDescriptor(p);
      map::updateNormalAndDepth(p);
      frame.matches[i].point = p;
      ++points_created;
    }
  }
  reference_keyframe_ = last_keyframe_ = kf;
  last_keyframe_frame_id_ = frame.id;
  local_keyframes_ = {kf};
  state_ = TrackingState::kOk;
  last_reference_ = kf;
  last_T_c_r_ = SE3::identity();
  last_frame_ = frame;
  velocity_.reset();
  // The recent motion starts again here: the frames before lie in another map's world (or none),
  // and a bridge over them would mix two worlds.
  recent_poses_.clear();
  recent_poses_.push_back({frame.timestamp, kf, SE3::identity(), frame.T_c_w, points_created});
  pushHistory(frame, kf, SE3::identity());
  records_.push_back({frame.id, frame.timestamp, kf, SE3::identity(), active_map_, PoseSource::kTracked});
  ++maps_started_;
  // A map started at a loss: the camera may still be where another map is (findInOtherMap()).
  if (maps_started_ > 1) search_other_maps_until_ = frame.timestamp + options_.atlas.other_map_search_s;
  first_sighting_.reset();
  outcome.tracked = true;
  outcome.new_keyframe = kf;
  outcome.new_map = true;
  settle(frame, std::nullopt, outcome);
  return true;
}

std::vector<matching::ProjectionCandidate> Tracker::motionCandidates(const map::Frame& from) const {
  const map::FeatureSet& last = *from.features;
  const auto& pyramid = *last.pyramid;
  const int top_level = static_cast<int>(pyramid.scale.size()) - 1;
  // Candidates: the frame's matched points, plus temporary points from its depth for close
  // features without a match (they keep tracking alive where the map is thin).
  std::vector<matching::ProjectionCandidate> candidates;
  std::shared_lock lock(map_.mutex());
  const SE3 T_w_c = from.T_c_w.inverse();
  for (size_t i = 0; i < last.size(); ++i) {
    if (!from.usable(i)) continue;
    const map::FeatureMatch& m = from.matches[i];
    matching::ProjectionCandidate c;
    if (m.point != nullptr && !m.outlier && !m.point->bad) {
      c.p_w = m.point->position;
      c.point = m.point;
    } else if (last.hasDepth(i) && last.depth[i] <= options_.tracking.close_depth) {
      c.p_w = T_w_c * camera_.backProject(last.uv[i], last.depth[i]);
    } else {
      continue;
    }
    const int level = last.level(i);
    c.descriptor = last.descriptor(i);
    c.min_level = std::max(0, level - 1);
    c.max_level = std::min(top_level, level + 1);
    c.radius = kMotionRadius * pyramid.scale[level];
    c.angle = last.keypoints[i].angle;
    candidates.push_back(c);
  }
  return candidates;
}

Tracker::SearchResult Tracker::searchFromPrediction(map::Frame& frame,
                                                    const std::vector<matching::ProjectionCandidate>& candidates,
                                                    const SE3& predicted_T_c_w, std::initializer_list<double> widen,
                                                    int min_matches) {
  frame.T_c_w = predicted_T_c_w;
  SearchResult result;
  for (double factor : widen) {
    frame.clearMatches();
    std::vector<matching::ProjectionCandidate> window = candidates;
    for (auto& c : window) c.radius *= factor;
    result.matches = matching::searchByProjection(frame, camera_, window, matcher_options_);
    if (result.matches >= kMinMotionMatches) break;
  }
  result.inliers = result.matches < min_matches ? 0 : optimizeFramePose(frame);
  return result;
}

bool Tracker::trackWithMotionModel(map::Frame& frame) {
  const std::vector<matching::ProjectionCandidate> candidates = motionCandidates(last_frame_);
  // One hypothesis: guided search around the points' predicted projections, widened once, then
  // pose-only optimisation. Returns the map-point inliers (0 when too few matches).
  auto attempt = [&](map::Frame& f, const SE3& predicted_T_c_w) {
    return searchFromPrediction(f, candidates, predicted_T_c_w, {1.0, 2.0}, kMinMotionMatches).inliers;
  };
  // Constant velocity in time, not per frame: a dropped frame doubles the motion to predict.
  int inliers = attempt(frame, motionOver(frame.timestamp - last_frame_.timestamp) * last_frame_.T_c_w);
  // People walking past a camera that stops can hold a constant-velocity prediction on their
  // motion (their features sit where the prediction looks). The constant-position hypothesis
  // competes whenever the velocity is not negligible; the one with more inliers wins.
  if (options_.tracking.still_camera_hypothesis &&
      (velocity_->translation().norm() > kStillTranslation || velocity_->rotationAngle() > kStillRotation)) {
    map::Frame still = frame;
    const int still_inliers = attempt(still, last_frame_.T_c_w);
    if (still_inliers > inliers) {
      frame = std::move(still);
      inliers = still_inliers;
    }
  }
  return inliers >= kMinMapInliersStep;
}

std::optional<SE3> Tracker::trackWithDepth(const map::Frame& frame, const SE3& predicted_T_c_w) {
  if (last_frame_.depth.empty() || frame.depth.empty()) return std::nullopt;
  if (!last_depth_pyramid_ || last_depth_pyramid_->first != last_frame_.id)
    last_depth_pyramid_.emplace(last_frame_.id, depth_aligner_->prepare(last_frame_.depth, last_frame_.dynamic_mask));
  DepthPyramid current = depth_aligner_->prepare(frame.depth, frame.dynamic_mask);
  const SE3 T_cur_last_guess = predicted_T_c_w * last_frame_.T_c_w.inverse();
  const DepthAlignmentResult r = depth_aligner_->align(last_depth_pyramid_->second, current, T_cur_last_guess);
  const SE3 T_c_w = r.T_cur_ref * last_frame_.T_c_w;
  spdlog::debug("tracking: frame {} depth alignment to frame {}: {} pairs, overlap {:.2f}, rms {:.4f} m, constraint "
                "{:.4f}, {:.3f} m and {:.2f} deg from the prediction: {}",
                frame.id, last_frame_.id, r.correspondences, r.overlap, r.rms_m, r.constraint,
                (T_c_w.inverse().translation() - predicted_T_c_w.inverse().translation()).norm(),
                (T_c_w * predicted_T_c_w.inverse()).rotationAngle() * 180.0 / M_PI,
                r.accepted ? "accepted" : r.refusal);
  if (!r.accepted) return std::nullopt;
  // The frame, if it keeps this pose, is the next one's reference.
  last_depth_pyramid_.emplace(frame.id, std::move(current));
  return T_c_w;
}

std::optional<Tracker::OdometryPose> Tracker::trackWithOdometry(const map::Frame& frame,
                                                                const map::Frame& last_frame) const {
  if (last_frame.features == nullptr || frame.features == nullptr) return std::nullopt;
  const map::FeatureSet& last = *last_frame.features;
  const map::FeatureSet& current = *frame.features;
  const int min_inliers = options_.tracking.odometry_min_inliers;
  // The last frame's static features with a 3-D point: its map point, else its own depth.
  std::vector<int> last_indices;
  std::vector<Vec3> last_p_w(last.size());
  std::vector<map::MapPoint*> last_points(last.size(), nullptr);
  {
    std::shared_lock lock(map_.mutex());
    const SE3 T_w_l = last_frame.T_c_w.inverse();
    for (size_t i = 0; i < last.size(); ++i) {
      if (!last_frame.usable(i)) continue;
      const map::FeatureMatch& m = last_frame.matches[i];
      if (m.point != nullptr && !m.outlier && !m.point->bad) {
        last_p_w[i] = m.point->position;
        last_points[i] = m.point;
      } else if (last.hasDepth(i) && last.depth[i] <= options_.tracking.max_depth) {
        last_p_w[i] = T_w_l * camera_.backProject(last.uv[i], last.depth[i]);
      } else {
        continue;
      }
      last_indices.push_back(static_cast<int>(i));
    }
  }
  std::vector<int> current_indices;
  for (size_t j = 0; j < current.size(); ++j)
    if (frame.usable(j)) current_indices.push_back(static_cast<int>(j));
  if (static_cast<int>(std::min(last_indices.size(), current_indices.size())) < min_inliers) return std::nullopt;

  // Descriptor matches within a window around the same pixel (no prediction), so that the ratio
  // test compares neighbours only and a repeated texture elsewhere does not void it.
  const double frames_elapsed = std::max(1.0, (frame.timestamp - last_frame.timestamp) * 30.0);
  const double window_px = std::min(kOdometryWindowPx * frames_elapsed, kOdometryMaxWindowPx);
  const std::vector<std::pair<int, int>> pairs = matching::matchDescriptors(
      last, last_indices, current, current_indices, kOdometryMaxDescriptorDistance, kOdometryMatchRatio,
      /*check_orientation=*/true,
      [&](int i, int j) { return (last.uv[i] - current.uv[j]).norm() <= window_px; });
  if (static_cast<int>(pairs.size()) < min_inliers) {
    spdlog::debug("tracking: frame {} odometry against frame {}: {} matches", frame.id, last_frame.id, pairs.size());
    return std::nullopt;
  }

  // RANSAC over rigid motions from three matches with depth on both sides (3-D to 3-D, so no
  // mirrored or depth-ambiguous solution as PnP on reprojection alone can give). An inlier
  // reprojects within relocalisation.ransac_reprojection_px and, where this frame has depth, lies
  // at that depth.
  std::vector<Vec3> p_c_measured(pairs.size(), Vec3::Zero());
  std::vector<int> with_depth;
  for (size_t k = 0; k < pairs.size(); ++k) {
    const int j = pairs[k].second;
    if (!current.hasDepth(j)) continue;
    p_c_measured[k] = camera_.backProject(current.uv[j], current.depth[j]);
    with_depth.push_back(static_cast<int>(k));
  }
  if (with_depth.size() < 3) return std::nullopt;
  const double max_px = options_.relocalisation.ransac_reprojection_px;
  const auto inliersOf = [&](const SE3& T_c_w, std::vector<int>* out) {
    int count = 0;
    for (size_t k = 0; k < pairs.size(); ++k) {
      const auto [i, j] = pairs[k];
      const Vec3 p_c = T_c_w * last_p_w[i];
      if (p_c.z() <= options_.tracking.min_depth) continue;
      if ((camera_.project(p_c) - current.uv[j]).norm() > max_px) continue;
      if (current.hasDepth(j) && std::abs(p_c.z() - current.depth[j]) > kOdometryDepthTolerance * current.depth[j])
        continue;
      ++count;
      if (out != nullptr) out->push_back(static_cast<int>(k));
    }
    return count;
  };
  const auto rigidFit = [&](const std::vector<int>& subset) {
    Eigen::Matrix3Xd from(3, subset.size()), to(3, subset.size());
    for (size_t n = 0; n < subset.size(); ++n) {
      from.col(static_cast<Eigen::Index>(n)) = last_p_w[pairs[subset[n]].first];
      to.col(static_cast<Eigen::Index>(n)) = p_c_measured[subset[n]];
    }
    const Eigen::Matrix4d T = Eigen::umeyama(from, to, /*with_scaling=*/false);
    return SE3(T.topLeftCorner<3, 3>(), T.topRightCorner<3, 1>());
  };
  std::mt19937 rng(static_cast<uint32_t>(frame.id));  // deterministic per frame
  std::uniform_int_distribution<size_t> pick(0, with_depth.size() - 1);
  SE3 best_T_c_w;
  int best = 0;
  for (int iteration = 0; iteration < options_.relocalisation.ransac_iterations; ++iteration) {
    const size_t a = pick(rng), b = pick(rng), c = pick(rng);
    if (a == b || b == c || a == c) continue;
    const SE3 T_c_w = rigidFit({with_depth[a], with_depth[b], with_depth[c]});
    if (!T_c_w.matrix().allFinite()) continue;
    const int n = inliersOf(T_c_w, nullptr);
    if (n > best) {
      best = n;
      best_T_c_w = T_c_w;
    }
  }
  if (best < min_inliers) {
    spdlog::debug("tracking: frame {} odometry against frame {}: {} matches, {} inliers at best", frame.id,
                  last_frame.id, pairs.size(), best);
    return std::nullopt;
  }
  // The fit of three points is only a hypothesis: the pose comes from pose-only optimisation on
  // its inliers (reprojection with the depth residual, robust), as tracking's own poses do; a
  // rigid fit of all inliers in 3-D would weigh the depth noise of far points like pixels (a
  // fr1_desk composite: 176 inliers, 4 cm off).
  const auto matchesOf = [&](const std::vector<int>& subset) {
    std::vector<map::FeatureMatch> matches(current.size());
    for (int k : subset) {
      const auto [i, j] = pairs[k];
      if (last_points[i] != nullptr) {
        matches[j].point = last_points[i];
      } else {
        matches[j].has_vo_point = true;
        matches[j].vo_point = last_p_w[i];
      }
    }
    return matches;
  };
  std::vector<int> inliers;
  inliersOf(best_T_c_w, &inliers);
  map::Frame refined = frame;
  refined.T_c_w = best_T_c_w;
  refined.matches = matchesOf(inliers);
  tracking::optimizeFramePose(refined, map_, camera_, bf_, /*vo_check_min_map_inliers=*/0);
  std::vector<int> refined_inliers;
  if (refined.T_c_w.matrix().allFinite() && inliersOf(refined.T_c_w, &refined_inliers) >= min_inliers) {
    best_T_c_w = refined.T_c_w;
    inliers = std::move(refined_inliers);
  }

  OdometryPose result;
  result.T_c_w = best_T_c_w;
  result.inliers = static_cast<int>(inliers.size());
  result.matches = matchesOf(inliers);
  spdlog::debug("tracking: frame {} odometry against frame {}: {} matches, {} inliers", frame.id, last_frame.id,
                pairs.size(), result.inliers);
  if (implausibleJump(result.T_c_w, frame.timestamp)) return std::nullopt;
  return result;
}

bool Tracker::implausibleJump(const SE3& T_c_w, Timestamp t) const {
  // A non-positive interval (equal timestamps) is taken as one frame at 30 Hz.
  const double seconds = std::max(t - last_frame_.timestamp, 1.0 / 30.0);
  const double moved = (T_c_w.inverse().translation() - last_frame_.T_c_w.inverse().translation()).norm();
  return moved > options_.tracking.max_speed_m_s * seconds;
}

Tracker::BridgeJudgement Tracker::judgeAgainstBridge(const map::Frame& frame, int map_inliers) const {
  const double a = options_.tracking.max_acceleration_m_s2;
  // Only a bridge resting on an established motion (kBridgeVelocityFrames tracked frames in a row)
  // is trusted to judge: one built on a single frame found again after a loss is no better than
  // the frame it would judge.
  if (a <= 0 || recent_poses_.size() < kBridgeVelocityFrames + 1) return BridgeJudgement::kAgrees;
  const double seconds = std::max(frame.timestamp - last_frame_.timestamp, 1.0 / 30.0);
  const SE3 bridged = bridgedPose(frame.timestamp);
  const double off_m = (frame.T_c_w.inverse().translation() - bridged.inverse().translation()).norm();
  const double limit_m = bridgeBoundM(a, seconds);
  // The last tracked frames are the ones a loss most often begins with: their poses may already
  // have followed walkers the mask missed (Bonn crowd: frame 319 8-9 cm off with 69 inliers and a
  // 1-frame-old mask, 320 or 321 lost after it), and a bridge extrapolated from them refused the
  // right poses after them (5-6 frames, 50-64 inliers each). Where one of the last two tracked
  // frames left the motion of the frames before it (by more than a weak pose may), a pose that
  // agrees with the bridge from the frame before that one, within the same bound, is accepted too.
  // The bridge over the tracked frames up to `last`, from that one.
  const auto bridgedFrom = [this](size_t last, Timestamp t) {
    return recentMotion(last, t).value_or(SE3::identity()) * recent_poses_[last].T_c_w;
  };
  bool refused = off_m > limit_m;
  for (size_t jumped = recent_poses_.size() - 1; refused && jumped + 2 >= recent_poses_.size(); --jumped) {
    const RecentPose& pose = recent_poses_[jumped];
    const double jump_m =
        (pose.T_c_w.inverse().translation() - bridgedFrom(jumped - 1, pose.timestamp).inverse().translation()).norm();
    if (jump_m <= kWeakMaxDeviationM) continue;
    const double off_before_m =
        (frame.T_c_w.inverse().translation() - bridgedFrom(jumped - 1, frame.timestamp).inverse().translation()).norm();
    spdlog::debug("tracking: frame {}: tracked frame at {:.3f} s left the motion before it by {:.3f} m; {:.3f} m from "
                  "the bridge from the frame before it", frame.id, pose.timestamp, jump_m, off_before_m);
    refused = off_before_m > limit_m;
  }
  // A bridge is only as good as the frames it extrapolates: a pose found again with far more
  // support than they had is trusted over it (tracking.bridge_overruled_inlier_ratio).
  const double ratio = options_.tracking.bridge_overruled_inlier_ratio;
  bool overruled = false;
  if (refused && ratio > 0) {
    std::vector<int> support;
    for (const RecentPose& pose : recent_poses_) support.push_back(pose.inliers);
    const double median = medianOf(support);
    spdlog::debug("tracking: frame {} found again with {} local-map inliers; the bridge's frames had {:.1f} (median)",
                  frame.id, map_inliers, median);
    overruled = map_inliers >= 2 * kMinLocalMapInliersAfterStage2 && map_inliers >= ratio * median;
  }
  spdlog::debug("tracking: frame {} found again {:.3f} m from the bridged pose after {:.3f} s (limit {:.3f} m): {}",
                frame.id, off_m, seconds, limit_m, !refused ? "accepted" : overruled ? "accepted (overruled)" : "refused");
  if (!refused) return BridgeJudgement::kAgrees;
  return overruled ? BridgeJudgement::kOverruled : BridgeJudgement::kRefused;
}

std::optional<SE3> Tracker::recentMotion(size_t last, Timestamp t) const {
  if (last == 0 || last >= recent_poses_.size()) return std::nullopt;
  const RecentPose& first = recent_poses_.front();
  const RecentPose& end = recent_poses_[last];
  if (!(end.timestamp - first.timestamp > 1e-6)) return std::nullopt;
  const SE3 motion = end.T_c_w * first.T_c_w.inverse();
  return SE3::exp(motion.log() * ((t - end.timestamp) / (end.timestamp - first.timestamp)));
}

SE3 Tracker::bridgedPose(Timestamp t) const {
  // Constant velocity over the last kBridgeVelocityFrames tracked frames, from the last one.
  if (!recent_poses_.empty())
    if (const std::optional<SE3> motion = recentMotion(recent_poses_.size() - 1, t)) return *motion * last_frame_.T_c_w;
  return motionOver(t - last_frame_.timestamp) * last_frame_.T_c_w;
}

SE3 Tracker::motionOver(double seconds) const {
  if (!velocity_) return SE3::identity();
  // A non-positive interval (equal timestamps) cannot scale the velocity: use it as it is.
  if (velocity_interval_s_ <= 1e-6) return *velocity_;
  return SE3::exp(velocity_->log() * (seconds / velocity_interval_s_));
}

bool Tracker::trackReferenceKeyframe(map::Frame& frame) { return trackKeyframe(frame, reference_keyframe_); }

bool Tracker::trackRecentKeyframes(map::Frame& frame) {
  std::vector<map::Keyframe*> recent;
  {
    std::shared_lock lock(map_.mutex());
    const std::vector<map::Keyframe*> all = map_.keyframes();
    for (auto it = all.rbegin(); it != all.rend() && recent.size() < kRecoveryKeyframes; ++it)
      if (*it != reference_keyframe_) recent.push_back(*it);
  }
  for (map::Keyframe* kf : recent) {
    if (trackKeyframe(frame, kf)) {
      reference_keyframe_ = kf;
      return true;
    }
  }
  return false;
}

bool Tracker::trackKeyframe(map::Frame& frame, map::Keyframe* keyframe) {
  if (keyframe == nullptr) return false;
  frame.clearMatches();
  std::vector<int> kf_indices, frame_indices;
  std::vector<map::MapPoint*> kf_points;
  {
    std::shared_lock lock(map_.mutex());
    if (keyframe->bad) return false;
    kf_points = keyframe->points;
  }
  for (size_t i = 0; i < kf_points.size(); ++i)
    if (kf_points[i] != nullptr) kf_indices.push_back(static_cast<int>(i));
  for (size_t i = 0; i < frame.features->size(); ++i)
    if (frame.usable(i)) frame_indices.push_back(static_cast<int>(i));
  const auto pairs = matching::matchDescriptors(*keyframe->features, kf_indices, *frame.features,
                                                frame_indices, matcher_options_.strict_distance, 0.7, true);
  if (static_cast<int>(pairs.size()) < 15) return false;
  {
    std::shared_lock lock(map_.mutex());
    for (auto [ikf, iframe] : pairs) {
      map::MapPoint* p = kf_points[ikf];
      if (p->bad) continue;
      frame.matches[iframe].point = p;
    }
  }
  {
    std::shared_lock lock(map_.mutex());
    // Start from the last tracked pose for the reference keyframe, from the keyframe otherwise.
    frame.T_c_w = keyframe == reference_keyframe_ ? last_frame_.T_c_w : keyframe->T_c_w;
  }
  return optimizeFramePose(frame) >= kMinMapInliersStep;
}

int Tracker::optimizeFramePose(map::Frame& frame) {
  return tracking::optimizeFramePose(frame, map_, camera_, bf_, options_.tracking.vo_check_min_map_inliers);
}

void Tracker::updateLocalMap(const map::Frame& frame) {
  // Keyframes voting by the points the frame sees; the most voted becomes the reference.
  std::map<uint64_t, std::pair<map::Keyframe*, int>> votes;
  for (const map::FeatureMatch& m : frame.matches) {
    if (m.point == nullptr || m.point->bad) continue;
    for (const auto& [kf_id, obs] : m.point->observations) {
      auto& v = votes[kf_id];
      v.first = obs.first;
      ++v.second;
    }
  }
  if (votes.empty()) return;
  local_keyframes_.clear();
  std::map<uint64_t, map::Keyframe*> chosen;
  map::Keyframe* best = nullptr;
  int best_votes = 0;
  std::vector<std::pair<int, map::Keyframe*>> voted;
  for (auto& [id, v] : votes) {
    if (v.first->bad) continue;
    voted.emplace_back(v.second, v.first);
    if (v.second > best_votes) {
      best_votes = v.second;
      best = v.first;
    }
  }
  std::sort(voted.begin(), voted.end(),
            [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second->id < b.second->id; });
  const size_t limit = static_cast<size_t>(options_.tracking.local_map_keyframes);
  for (auto& [n, kf] : voted) {
    if (chosen.size() >= limit) break;
    chosen[kf->id] = kf;
  }
  // Neighbours of the voted keyframes widen the local map.
  for (auto& [n, kf] : voted) {
    if (chosen.size() >= limit) break;
    for (map::Keyframe* neighbour : map::bestCovisibles(kf, 10)) {
      if (chosen.size() >= limit) break;
      chosen.emplace(neighbour->id, neighbour);
    }
    if (kf->parent != nullptr && !kf->parent->bad && chosen.size() < limit) chosen.emplace(kf->parent->id, kf->parent);
  }
  for (auto& [id, kf] : chosen) local_keyframes_.push_back(kf);
  if (best != nullptr) reference_keyframe_ = best;

  local_points_.clear();
  for (map::Keyframe* kf : local_keyframes_) {
    for (map::MapPoint* p : kf->points) {
      if (p == nullptr || p->bad) continue;
      if (point_stamp_.size() <= p->id) point_stamp_.resize(p->id * 2 + 1024, UINT64_MAX);
      if (point_stamp_[p->id] == frame.id) continue;
      point_stamp_[p->id] = frame.id;
      local_points_.push_back(p);
    }
  }
}

bool Tracker::trackLocalMap(map::Frame& frame, int& inliers) {
  const map::FeatureSet& features = *frame.features;
  const auto& pyramid = *features.pyramid;
  const Vec3 center = frame.T_c_w.inverse().translation();
  std::vector<matching::ProjectionCandidate> candidates;
  {
    std::shared_lock lock(map_.mutex());
    updateLocalMap(frame);
    std::vector<uint64_t> matched_ids;
    for (const map::FeatureMatch& m : frame.matches)
      if (m.point != nullptr) matched_ids.push_back(m.point->id);
    std::sort(matched_ids.begin(), matched_ids.end());
    for (map::MapPoint* p : local_points_) {
      if (std::binary_search(matched_ids.begin(), matched_ids.end(), p->id)) continue;
      // Frustum and scale-invariance checks.
      const Vec3 p_c = frame.T_c_w * p->position;
      if (p_c.z() <= 0.05) continue;
      const Vec2 uv = camera_.project(p_c);
      if (!camera_.inImage(uv)) continue;
      const Vec3 ray = p->position - center;
      const double distance = ray.norm();
      if (distance < p->min_distance * 0.8 || distance > p->max_distance * 1.2) continue;
      const double view_cos = ray.dot(p->normal) / distance;
      if (view_cos < 0.5) continue;
      ++p->visible;
      const int level = map::predictLevel(p, distance, pyramid);
      matching::ProjectionCandidate c;
      c.p_w = p->position;
      c.point = p;
      c.descriptor = p->descriptor.ptr<uint8_t>();
      c.min_level = std::max(0, level - 1);
      c.max_level = level;
      c.radius = kLocalMapRadius * (view_cos > 0.998 ? 2.5 : 4.0) * pyramid.scale[level];
      candidates.push_back(c);
    }
    // The search reads the candidates' map-point descriptors: keep the shared lock.
    matching::searchByProjection(frame, camera_, candidates, matcher_options_);
    verifyMaskedFeaturesByMap(frame, candidates);
  }
  inliers = optimizeFramePose(frame);
  // A masked feature the map vouched for but the pose does not fit (its match cleared as an
  // outlier) goes back to being dropped.
  for (size_t i = 0; i < frame.map_verifiable.size(); ++i) {
    if (frame.map_verifiable[i] != map::kMapVerified || frame.matches[i].matched()) continue;
    frame.map_verifiable[i] = 0;
    frame.status[i] = map::FeatureStatus::kDynamicStage1;
  }
  {
    std::shared_lock lock(map_.mutex());
    for (const map::FeatureMatch& m : frame.matches)
      if (m.point != nullptr && !m.point->bad) ++m.point->found;
  }
  return inliers >= kMinLocalMapInliers;
}

void Tracker::verifyMaskedFeaturesByMap(map::Frame& frame, const std::vector<matching::ProjectionCandidate>& candidates) {
  if (std::find(frame.map_verifiable.begin(), frame.map_verifiable.end(), map::kMapVerifiable) ==
      frame.map_verifiable.end())
    return;
  // The points no static feature took, searched for among those masked features alone.
  std::vector<uint64_t> matched_ids;
  for (const map::FeatureMatch& m : frame.matches)
    if (m.point != nullptr) matched_ids.push_back(m.point->id);
  std::sort(matched_ids.begin(), matched_ids.end());
  std::vector<matching::ProjectionCandidate> rest;
  for (const matching::ProjectionCandidate& c : candidates)
    if (c.point != nullptr && !std::binary_search(matched_ids.begin(), matched_ids.end(), c.point->id))
      rest.push_back(c);
  std::vector<uint8_t> eligible(frame.map_verifiable.size(), 0);
  for (size_t i = 0; i < eligible.size(); ++i) eligible[i] = frame.map_verifiable[i] == map::kMapVerifiable ? 1 : 0;
  matching::ProjectionSearchScope scope;
  scope.eligible = &eligible;
  scope.max_relative_depth_residual = options_.dynamic.stage1_threshold;
  matching::searchByProjection(frame, camera_, rest, matcher_options_, scope);
  for (size_t i = 0; i < eligible.size(); ++i) {
    if (!eligible[i] || frame.matches[i].point == nullptr) continue;
    frame.map_verifiable[i] = map::kMapVerified;
    frame.status[i] = map::FeatureStatus::kStatic;
  }
}

bool Tracker::needKeyframe(const map::Frame& frame, int inliers, bool mapping_idle, int mapping_backlog) const {
  const auto& t = options_.tracking;
  if (mapping_backlog >= kMaxMappingBacklog && inliers >= kMinLocalMapInliers) return false;
  const uint64_t since_last = frame.id - last_keyframe_frame_id_;
  if (static_cast<int>(since_last) < t.min_frames_between_keyframes) return false;
  // A crowded view: keyframes spaced out (see tracking.crowded_keyframe_spacing).
  if (static_cast<int>(since_last) < t.crowded_keyframe_spacing && !frame.dynamic_mask.empty() &&
      maskedShare(frame) >= t.crowded_view_share)
    return false;

  int reference_tracked = 0;
  SE3 T_c_lastkf;
  size_t keyframes = 0;
  {
    std::shared_lock lock(map_.mutex());
    keyframes = map_.keyframeCount(active_map_);
    reference_tracked = map::trackedPointCount(reference_keyframe_, keyframes <= 2 ? 2 : 3);
    T_c_lastkf = frame.T_c_w * map::keyframeTcw(last_keyframe_).inverse();
  }
  const map::FeatureSet& features = *frame.features;
  int tracked_close = 0, untracked_close = 0;
  for (size_t i = 0; i < features.size(); ++i) {
    if (!frame.usable(i) || !features.hasDepth(i) || features.depth[i] > t.close_depth) continue;
    const map::FeatureMatch& m = frame.matches[i];
    if (m.point != nullptr && !m.outlier)
      ++tracked_close;
    else
      ++untracked_close;
  }
  const bool need_close = tracked_close < kCloseTrackedNeeded && untracked_close > kCloseUntrackedEnough;
  const double ratio = keyframes < 2 ? 0.4 : t.keyframe_tracked_ratio;

  const bool timeout = static_cast<int>(since_last) >= t.max_frames_between_keyframes;
  const bool weak = inliers < 0.25 * reference_tracked || need_close;
  const bool fewer_than_reference = (inliers < ratio * reference_tracked || need_close) && inliers > 15;
  // Pose-change criteria: a fast turn or move gets a keyframe even if matching still holds; a
  // still camera gets none while tracking holds.
  const double moved_m = T_c_lastkf.translation().norm();
  const double turned_deg = T_c_lastkf.rotationAngle() * 180.0 / M_PI;
  const bool moved = moved_m > t.keyframe_translation || turned_deg > t.keyframe_rotation_deg;
  const bool still = moved_m < t.keyframe_still_translation && turned_deg < t.keyframe_still_rotation_deg;
  if (still && inliers >= kMinLocalMapInliers) return false;
  return ((timeout || mapping_idle || weak) && fewer_than_reference) || (moved && inliers > 15);
}

cv::Mat Tracker::halfDepthFor(const map::Frame& frame) const {
  if (!stage2_enabled_ || frame.depth.empty()) return {};
  return dynamic::makeHalfResolutionDepth(frame.depth);
}

void Tracker::applyStage1(map::Frame& frame, TrackOutcome& outcome) {
  const bool geometric_only = options_.dynamic.mode == DynamicMode::kGeometric;
  dynamic::Stage1Input input;
  input.current = frame.features.get();
  input.current_depth = &frame.depth;
  input.mask = geometric_only || frame.dynamic_mask.empty() ? nullptr : &frame.dynamic_mask;
  input.mask_is_dilated = true;
  const map::Frame& reference = stage1Reference(frame);
  input.previous = reference.features.get();
  input.T_k_km1 = frame.T_c_w * reference.T_c_w.inverse();
  // Features outside the mask (all of them when this frame has none): the free-space test.
  std::vector<uint8_t> outside(frame.status.size(), 0);
  for (size_t i = 0; i < frame.status.size(); ++i)
    outside[i] = frame.status[i] == map::FeatureStatus::kStatic ? 1 : 0;
  if (input.mask != nullptr || geometric_only) {
    const dynamic::Stage1Result result = dynamic::runStage1(input, camera_, options_.dynamic);
    outcome.stage1_checked = result.in_mask_count;
    spdlog::debug("stage 1: frame {} against frame {}: {} in the mask, {} consistent, {} dynamic, {} without depth, "
                  "{} unmatched", frame.id, reference.id, result.in_mask_count, result.consistent_count,
                  result.dynamic_count, result.no_depth_count, result.unmatched_count);
    // Only in the ring a late mask's growth adds: inside the network's mask and its dilation a map
    // point can be a person's (mapped while the network missed them; features on the silhouette)
    // and would vouch for the person's features. A fresh mask has no such ring.
    const bool map_check = options_.dynamic.stage1_map_check && !geometric_only && !frame.ungrown_mask.empty() &&
                           options_.dynamic.stage1_unmatched_policy == UnmatchedPolicy::kDrop;
    const std::vector<uint8_t> in_ungrown =
        map_check ? dynamic::featuresInMask(*frame.features, frame.ungrown_mask) : std::vector<uint8_t>();
    frame.map_verifiable.clear();
    for (size_t i = 0; i < frame.status.size(); ++i) {
      if (frame.status[i] != map::FeatureStatus::kPendingStage1 && frame.status[i] != map::FeatureStatus::kStatic)
        continue;
      if (result.dynamic[i]) {
        frame.status[i] = map::FeatureStatus::kDynamicStage1;
        frame.matches[i] = {};
        ++outcome.stage1_removed;
        const dynamic::Stage1Outcome why = result.outcome[i];
        if (map_check && !in_ungrown[i] && frame.features->hasDepth(i) &&
            (why == dynamic::Stage1Outcome::kUnmatched || why == dynamic::Stage1Outcome::kNoDepth)) {
          if (frame.map_verifiable.empty()) frame.map_verifiable.assign(frame.status.size(), 0);
          frame.map_verifiable[i] = map::kMapVerifiable;
        }
      } else {
        frame.status[i] = map::FeatureStatus::kStatic;
      }
    }
  } else {
    for (auto& status : frame.status)  // no mask for this frame: nothing is pending
      if (status == map::FeatureStatus::kPendingStage1) status = map::FeatureStatus::kStatic;
  }
  if (geometric_only || !options_.dynamic.free_space_outside_mask || reference.depth.empty() || reference.id == frame.id)
    return;
  dynamic::FreeSpaceInput free_space;
  free_space.current = frame.features.get();
  free_space.reference_depth = &reference.depth;
  free_space.T_ref_k = input.T_k_km1.inverse();
  free_space.test = &outside;
  std::vector<uint8_t> moved = dynamic::freeSpaceViolations(free_space, camera_, options_.dynamic);
  {
    // The reference keyframe too: seconds rather than 0.2 s back, it also catches a person whose
    // body still covers the same pixels after 0.2 s (Bonn crowd, emulated real-time masks: mean
    // ATE of four latencies 0.037 -> 0.034 m; static sequences unchanged).
    std::shared_lock lock(map_.mutex());
    if (reference_keyframe_ != nullptr && !reference_keyframe_->half_depth.empty()) {
      dynamic::FreeSpaceInput kf_space = free_space;
      kf_space.reference_depth = &reference_keyframe_->half_depth;
      kf_space.depth_scale = 2;
      kf_space.T_ref_k = reference_keyframe_->T_c_w * frame.T_c_w.inverse();
      const std::vector<uint8_t> moved_kf = dynamic::freeSpaceViolations(kf_space, camera_, options_.dynamic);
      for (size_t i = 0; i < moved.size(); ++i) moved[i] |= moved_kf[i];
    }
  }
  for (size_t i = 0; i < moved.size(); ++i) {
    if (!moved[i]) continue;
    frame.status[i] = map::FeatureStatus::kDynamicStage1;
    frame.matches[i] = {};
    ++outcome.stage1_removed;
    ++outcome.free_space_removed;
  }
}

const map::Frame& Tracker::stage1Reference(const map::Frame& frame) const {
  for (auto it = history_.rbegin(); it != history_.rend(); ++it)
    if (frame.timestamp - it->frame.timestamp >= options_.dynamic.stage1_min_interval_s) return it->frame;
  return history_.empty() ? last_frame_ : history_.front().frame;
}

int Tracker::applyStage2(map::Frame& frame) {
  std::vector<map::MapPoint*> culled;
  {
    std::shared_lock lock(map_.mutex());
    if (reference_keyframe_ == nullptr) return 0;
    std::vector<map::Keyframe*> candidates{reference_keyframe_};
    for (map::Keyframe* kf : map::bestCovisibles(reference_keyframe_, 3 * options_.dynamic.stage2_keyframes))
      candidates.push_back(kf);
    std::vector<dynamic::KeyframeDepthView> views;
    for (size_t i = 0; i < frame.matches.size(); ++i) {
      map::MapPoint* p = frame.matches[i].point;
      if (p == nullptr || p->bad || frame.matches[i].outlier) continue;
      // Keyframes observing the point agree with it by construction: ask the others.
      views.clear();
      for (map::Keyframe* kf : candidates) {
        if (static_cast<int>(views.size()) >= options_.dynamic.stage2_keyframes) break;
        if (kf->bad || kf->half_depth.empty() || p->observations.count(kf->id) != 0) continue;
        views.push_back({kf->T_c_w, &kf->half_depth});
      }
      if (views.empty()) continue;
      if (dynamic::checkStage2(p->position, views, camera_, options_.dynamic).dynamic) {
        frame.status[i] = map::FeatureStatus::kDynamicStage2;
        frame.matches[i] = {};
        culled.push_back(p);
      }
    }
  }
  if (!culled.empty()) {
    std::unique_lock lock(map_.mutex());
    for (map::MapPoint* p : culled) map_.setPointBad(p);
  }
  return static_cast<int>(culled.size());
}

std::optional<std::vector<map::FeatureStatus>> Tracker::mappableStatus(const map::Frame& frame, int inliers) const {
  std::vector<map::FeatureStatus> status = frame.status;
  if (frame.mapping_margin_px <= 0 || frame.dynamic_mask.empty()) return status;
  const std::vector<uint8_t> excluded = featuresNearPeople(frame);
  int mappable = 0;
  for (size_t i = 0; i < status.size(); ++i) {
    if (excluded[i] && status[i] == map::FeatureStatus::kStatic) status[i] = map::FeatureStatus::kDynamicMask;
    mappable += status[i] == map::FeatureStatus::kStatic && (frame.matches[i].point != nullptr || frame.features->hasDepth(i));
  }
  // A keyframe with little left to observe is barely constrained: bundle adjustment can move it
  // anywhere (Bonn crowd, emulated late masks: one ended 2 m away). Fewer are accepted only when
  // tracking itself is about to starve (without a keyframe the map would not grow there). The
  // margin itself stays: narrowing it in a crowd (tried: 40 px halved down to none while fewer
  // than 100 were left) made keyframes of walkers' unmasked limbs frame after frame, and Bonn
  // crowd drifted to 0.47 m for a second (ATE 0.055 m).
  const bool starving = inliers < kStarvingInliers;
  if (mappable >= kMinKeyframeObservations || (starving && mappable >= kMinKeyframeObservationsStarving)) return status;
  return std::nullopt;
}

map::Keyframe* Tracker::createKeyframe(map::Frame& frame, int inliers, bool hold_pose, bool weak_pose) {
  map::Keyframe* kf = nullptr;
  // The mapping margin's dilation is computed before taking the lock.
  const std::optional<std::vector<map::FeatureStatus>> mappable = mappableStatus(frame, inliers);
  if (!mappable) return nullptr;
  const std::vector<map::FeatureStatus>& status = *mappable;
  {
    std::unique_lock lock(map_.mutex());
    kf = map_.createKeyframe(frame.id, frame.timestamp, frame.image_name, frame.features, status,
                             halfDepthFor(frame), frame.T_c_w, active_map_);
    kf->pose_held = hold_pose;
    kf->made_at_weak_pose = weak_pose;
    for (size_t i = 0; i < frame.matches.size(); ++i) {
      map::MapPoint* p = frame.matches[i].point;
      if (status[i] != map::FeatureStatus::kStatic) continue;
      if (p != nullptr && !p->bad && !frame.matches[i].outlier && p->observations.count(kf->id) == 0)
        map::addObservation(p, kf, static_cast<int>(i));
    }
    createDepthPoints(frame, status, kf);
  }
  reference_keyframe_ = last_keyframe_ = kf;
  last_keyframe_frame_id_ = frame.id;
  return kf;
}

void Tracker::createDepthPoints(map::Frame& frame, const std::vector<map::FeatureStatus>& status, map::Keyframe* kf) {
  const map::FeatureSet& features = *frame.features;
  std::vector<std::pair<float, int>> by_depth;
  for (size_t i = 0; i < features.size(); ++i)
    if (status[i] == map::FeatureStatus::kStatic && features.hasDepth(i) && kf->points[i] == nullptr)
      by_depth.emplace_back(features.depth[i], i);
  std::sort(by_depth.begin(), by_depth.end());
  const SE3 T_w_c = frame.T_c_w.inverse();
  int created = 0;
  for (auto [depth, i] : by_depth) {
    // All close points, and at least the nearest kMinNewDepthPoints.
    if (depth > options_.tracking.close_depth && created >= kMinNewDepthPoints) break;
    map::MapPoint* p = map_.createPoint(T_w_c * camera_.backProject(features.uv[i], depth), kf);
    map::addObservation(p, kf, i);
    map::updateDescriptor(p);
    map::updateNormalAndDepth(p);
    frame.matches[i].point = p;
    frame.matches[i].has_vo_point = false;
    ++created;
  }
}

}  // namespace desslam::tracking
