#include "system/slam_system.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>
#include <shared_mutex>

#include <open3d/geometry/PointCloud.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "dense/dense_thread.hpp"
#include "dense/map_export.hpp"
#include "dense/memory_usage.hpp"
#include "dynamic/mask_utils.hpp"
#include "io/timing_summary.hpp"
#include "place/vocabulary_location.hpp"
#include "optim/map_bundle_adjustment.hpp"
#include "semantic/semantic_thread.hpp"
#include "semantic/segmenter.hpp"
#include "system/debug_view.hpp"

namespace desslam::system {

using io::summarizeMilliseconds;

namespace {
double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

constexpr int kDynamicFeatureRadius = 12;   // pixels left out of the dense map around a dynamic feature

std::unique_ptr<place::KeyframeDatabase> makeKeyframeDatabase(const SystemOptions& options) {
  if (!options.relocalisation.enabled && !options.loop.enabled) return nullptr;
  options.relocalisation.validate();  // names a bad key before the vocabulary is looked for
  return std::make_unique<place::KeyframeDatabase>(place::loadVocabulary(options.relocalisation.vocabulary),
                                                  options.relocalisation.direct_index_level);
}
}  // namespace

SlamSystem::SlamSystem(const SystemOptions& options, const RunSettings& settings)
    : options_(options),
      settings_(settings),
      camera_(options.camera),
      extractor_(options.orb),
      pyramid_(std::make_shared<feature::ScalePyramid>(extractor_.pyramid())),
      keyframe_db_(makeKeyframeDatabase(options)),
      tracker_(trackerOptions(options), camera_, map_, keyframe_db_.get()),
      mapper_(localMapperOptions(options), camera_, map_, keyframe_db_.get()),
      // Across an unknown motion the odometry frame extrapolates no longer than tracking predicts.
      odometry_(options.tracking.predict_through_loss_s) {
  options_.validate();
  if (settings_.mask_latency_frames < 0 || settings_.mask_period_frames < 1 ||
      (settings_.mask_latency_frames > 0 && settings_.realtime))
    throw ConfigError("mask latency emulation: latency must be >= 0 and period >= 1, and real-time mode has its own "
                      "latency (leave the emulation off with --realtime)");
  if (options_.loop.enabled)
    loop_closer_ = std::make_unique<loop::LoopCloser>(
        loopCloserOptions(options_), camera_, map_, *keyframe_db_, settings_.deterministic ? nullptr : &mapping_pause_,
        settings_.deterministic ? loop::GlobalBaMode::kInline : loop::GlobalBaMode::kThread);
  if (usesMask(options_.dynamic.mode)) {
    std::unique_ptr<semantic::Segmenter> segmenter = semantic::makeSegmenter(options_.semantic);
    if (segmenter == nullptr)
      throw ConfigError(std::string("dynamic.mode = ") + nameOf(options_.dynamic.mode) +
                        " needs masks but semantic.segmenter = none: choose deeplab or mask_dir, or dynamic.mode "
                        "geometric/off");
    semantic_ = std::make_unique<semantic::SemanticThread>(
        std::move(segmenter), settings_.realtime ? semantic::SemanticMode::kRealtime : semantic::SemanticMode::kOffline,
        options_.semantic.realtime_max_rate_hz);
  }
  if (!settings_.deterministic) {
    if (loop_closer_)
      loop_thread_ = std::make_unique<loop::LoopClosingThread>(*loop_closer_, options_.loop.queue_capacity);
    std::function<void(map::Keyframe*)> after_mapping;  // on the local-mapping thread
    if (loop_thread_ || settings_.after_local_mapping)
      after_mapping = [this](map::Keyframe* kf) {
        if (settings_.after_local_mapping) settings_.after_local_mapping(kf->id);
        if (loop_thread_) loop_thread_->push(kf);
      };
    mapping_thread_ = std::make_unique<mapping::LocalMappingThread>(
        mapper_, &mapping_pause_, std::move(after_mapping), [this](map::Keyframe* kf) { applyKeyframeMask(kf); });
  }
  // The plain core (dynamic.mode off) has no dynamic-scene handling at all, in the dense map too.
  if (options_.dynamic.mode == DynamicMode::kOff) options_.dense.carve_free_space = false;
  if (options_.dense.enabled)
    dense_ = std::make_unique<dense::DenseMappingThread>(
        options_.dense, camera_, settings_.realtime ? QueueFullPolicy::kDropOldest : QueueFullPolicy::kBlock);
  if (!settings_.debug_images_dir.empty()) std::filesystem::create_directories(settings_.debug_images_dir);
}

SlamSystem::~SlamSystem() {
  try {
    finish();
  } catch (...) {  // a worker's failure nobody asked for: the threads are stopped all the same
  }
}

void SlamSystem::rethrowWorkerFailure() {
  if (failure_reported_) return;
  const auto report = [this](const char* thread, const std::exception_ptr& failure) {
    if (!failure) return;
    failure_reported_ = true;
    throw WorkerError(std::string("the ") + thread + " thread failed: " + exceptionMessage(failure), failure);
  };
  if (mapping_thread_) report("local-mapping", mapping_thread_->failure());
  if (loop_thread_) report("loop-closing", loop_thread_->failure());
  if (loop_closer_) report("global bundle adjustment", loop_closer_->failure());
  if (dense_) report("dense-mapping", dense_->failure());
}

cv::Mat SlamSystem::maskFor(uint64_t frame_id, const std::shared_ptr<const cv::Mat>& bgr,
                            const std::string& image_name, const std::vector<cv::KeyPoint>& keypoints,
                            FrameStats& stats, cv::Mat& ungrown) {
  last_labels_ = cv::Mat();
  ungrown = cv::Mat();
  if (!semantic_) return {};
  const auto wait_start = std::chrono::steady_clock::now();
  std::shared_ptr<const semantic::Segmentation> result;
  uint64_t result_id = frame_id;
  const bool lost = tracker_.state() != tracking::TrackingState::kOk;
  if (carriesMasks() && lost && options_.semantic.own_mask_when_lost) {
    semantic_->requestOwnMask(frame_id, bgr, image_name);
    result = semantic_->waitForOwnMask(frame_id);
    stats.own_mask_waited = true;
  } else if (settings_.realtime) {
    // The frame may end up to half a frame period behind the sensor: the frames after it do not
    // wait (the network rests) and catch up. So: 1.5 frame periods minus what the previous frame
    // took besides waiting for its mask, and minus how far behind the sensor this one already is.
    const double period_ms = 1000.0 / options_.camera.fps;
    const double budget_ms =
        std::min(options_.semantic.realtime_mask_wait_ms,
                 1.5 * period_ms - (previous_processing_ms_ + kRealtimeMargin_ms + realtime_behind_ms_));
    if (budget_ms > 0)
      semantic_->waitUntilFinished(frame_id, std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                 std::chrono::duration<double, std::milli>(budget_ms)));
    result = semantic_->latest(frame_id, &result_id);
  } else if (settings_.mask_latency_frames > 0) {
    const uint64_t latency = static_cast<uint64_t>(settings_.mask_latency_frames);
    const uint64_t period = static_cast<uint64_t>(settings_.mask_period_frames);
    if (frame_id < latency) return {};
    result_id = (frame_id - latency) / period * period;
    if (emulated_result_ == nullptr || emulated_result_id_ != result_id) {
      emulated_result_ = semantic_->waitFor(result_id);
      emulated_result_id_ = result_id;
    }
    result = emulated_result_;
  } else {
    result = semantic_->waitFor(frame_id);
  }
  stats.mask_wait_ms = millisecondsSince(wait_start);
  if (result == nullptr || result->dynamic_mask.empty()) return {};
  stats.segmentation_ms = result->seconds * 1000.0;
  stats.mask_age = static_cast<int>(frame_id - result_id);
  last_labels_ = result->labels;
  cv::Mat mask = result->dynamic_mask;
  if (result_id != frame_id) {
    // Carry the older mask forward along the optical flow since its frame: it follows the people's
    // own motion as well as the camera's. Empty when older than the flow kept.
    mask = mask_propagator_.carry(result_id, mask);
    last_labels_ = cv::Mat();
  }
  if (options_.dynamic.mask_hold_previous) {
    if (current_result_ != result) {  // a new segmentation: the one before it is held
      held_result_ = current_result_;
      held_result_id_ = current_result_id_;
      current_result_ = result;
      current_result_id_ = result_id;
    }
    if (held_result_ != nullptr && !held_result_->dynamic_mask.empty() && !mask.empty()) {
      const cv::Mat held = mask_propagator_.carry(held_result_id_, held_result_->dynamic_mask);
      if (!held.empty()) {
        cv::Mat united;
        cv::bitwise_or(mask != 0, held != 0, united);
        mask = united;
      }
    }
  }
  if (mask.empty()) return {};
  const DynamicOptions& d = options_.dynamic;
  const int growth = std::min(std::max(0, stats.mask_age) * d.carried_mask_growth_px, d.carried_mask_max_growth_px);
  dynamic::GrownMask grown = dynamic::dilateMaskLeavingFeatures(mask, keypoints, d.mask_dilation_px, growth,
                                                               d.carried_mask_growth_px, d.carried_mask_min_outside_share);
  stats.mask_radius_px = grown.radius_px;
  ungrown = grown.base_mask;
  return grown.mask;
}

void SlamSystem::processFrame(Timestamp timestamp, const cv::Mat& bgr, const cv::Mat& depth,
                              const std::string& image_name, double depth_time_offset) {
  rethrowWorkerFailure();
  const auto start = std::chrono::steady_clock::now();
  FrameStats stats;
  const uint64_t frame_id = next_frame_id_++;
  if (settings_.realtime) {
    // How far behind the sensor this frame starts (the first frame sets the clock).
    if (frame_id == 0) realtime_origin_ = {start, timestamp};
    const double behind_ms =
        1000.0 * (std::chrono::duration<double>(start - realtime_origin_.wall).count() - (timestamp - realtime_origin_.timestamp));
    realtime_behind_ms_ = std::max(0.0, behind_ms);
  }
  // Segmentation of this frame runs in the semantic thread while ORB features are extracted here.
  // Messages to other threads own their pixels (a copy): cv::Mat's reference count is invisible to
  // ThreadSanitizer, and the caller may reuse its buffers.
  std::shared_ptr<const cv::Mat> shared_bgr;
  if (semantic_) {
    shared_bgr = std::make_shared<const cv::Mat>(bgr.clone());
    semantic_->submit(frame_id, shared_bgr, image_name);
  }

  cv::Mat gray;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  extractor_.extract(gray, keypoints, descriptors);
  if (tracksFlow() && semantic_) mask_propagator_.addFrame(frame_id, gray);
  stats.extraction_ms = millisecondsSince(start);

  cv::Mat ungrown_mask;
  const cv::Mat dynamic_mask = maskFor(frame_id, shared_bgr, image_name, keypoints, stats, ungrown_mask);
  if (!dynamic_mask.empty()) {
    const auto topup_start = std::chrono::steady_clock::now();
    // While tracking, dynamic.min_features_outside_mask features of any kind keep the track. Lost
    // (or not started), the frame may have to start a map, which takes atlas.min_initial_features
    // with depth: a target met by depthless ones would leave a crowded view unable to start one.
    // (Only then: more features in a crowd are also more on the people the mask misses.)
    const bool may_start_map = options_.atlas.enabled && tracker_.state() != tracking::TrackingState::kOk;
    const int wanted = options_.dynamic.min_features_outside_mask <= 0 ? 0
                       : may_start_map ? std::max(options_.dynamic.min_features_outside_mask,
                                                  options_.atlas.min_initial_features)
                                       : options_.dynamic.min_features_outside_mask;
    stats.features_added_outside_mask =
        feature::topUpOutside(extractor_, gray, dynamic_mask, may_start_map ? depth : cv::Mat(),
                              options_.tracking.min_depth, options_.tracking.max_depth, wanted, keypoints, descriptors);
    stats.extraction_ms += millisecondsSince(topup_start);
  }
  auto features = map::buildFeatureSet(std::move(keypoints), std::move(descriptors), camera_, depth, pyramid_,
                                       options_.tracking.min_depth, options_.tracking.max_depth);
  map::Frame frame(frame_id, timestamp, image_name, std::move(features));
  frame.depth = depth;
  frame.depth_time_offset = depth_time_offset;
  frame.dynamic_mask = dynamic_mask;
  frame.ungrown_mask = ungrown_mask;
  if (!dynamic_mask.empty()) frame.mapping_margin_px = options_.dynamic.mapping_margin_px;
  stats.features = static_cast<int>(frame.features->size());
  for (size_t i = 0; i < frame.features->size(); ++i) stats.features_with_depth += frame.features->hasDepth(i) ? 1 : 0;
  if (!frame.dynamic_mask.empty()) {
    const std::vector<uint8_t> in_mask = dynamic::featuresInMask(*frame.features, frame.dynamic_mask);
    const bool semantic_only = options_.dynamic.mode == DynamicMode::kSemantic;
    for (size_t i = 0; i < in_mask.size(); ++i) {
      if (!in_mask[i]) continue;
      ++stats.in_mask;
      frame.status[i] = semantic_only ? map::FeatureStatus::kDynamicMask : map::FeatureStatus::kPendingStage1;
    }
    if (semantic_only) stats.semantic_removed = stats.in_mask;
  }

  const auto track_start = std::chrono::steady_clock::now();
  const bool mapping_idle = mapping_thread_ == nullptr || mapping_thread_->idle();
  const int mapping_backlog = mapping_thread_ == nullptr ? 0 : mapping_thread_->backlog();
  const tracking::TrackOutcome outcome = tracker_.track(frame, mapping_idle, mapping_backlog);
  stats.tracking_ms = millisecondsSince(track_start);
  for (size_t i = 0; i < frame.features->size(); ++i)
    stats.static_with_depth += frame.usable(i) && frame.features->hasDepth(i) ? 1 : 0;
  stats.tracked = outcome.tracked;
  stats.stage1_checked = outcome.stage1_checked;
  stats.stage1_removed = outcome.stage1_removed;
  stats.free_space_removed = outcome.free_space_removed;
  stats.map_verified = outcome.map_verified;
  stats.stage2_removed = outcome.stage2_removed;
  stats.inliers = outcome.inliers;
  stats.motion_model = outcome.used_motion_model;
  stats.new_map = outcome.new_map;
  stats.weak = outcome.weak;
  stats.predicted = outcome.predicted;
  stats.odometry = outcome.odometry;
  stats.depth_odometry = outcome.depth_odometry;
  if (outcome.relocalisation) {
    const tracking::RelocalisationResult& r = *outcome.relocalisation;
    stats.reloc_candidates = r.candidates;
    stats.reloc_matches = r.best_matches;
    stats.reloc_pnp_inliers = r.best_pnp_inliers;
    stats.reloc_inliers = r.success ? r.inliers : r.best_inliers;
  }
  stats.timestamp = timestamp;
  if ((outcome.tracked || outcome.predicted) && !tracker_.records().empty()) stats.map = tracker_.records().back().map_id;
  // Earlier frames settled now (frames_[i] is frame i's): in this frame's map.
  const auto settled = [&](const std::vector<uint64_t>& ids, bool FrameStats::*flag) {
    for (uint64_t id : ids)
      if (id < frames_.size()) {
        frames_[id].*flag = true;
        frames_[id].map = stats.map;
      }
  };
  settled(outcome.backfilled, &FrameStats::backfilled);
  settled(outcome.interpolated, &FrameStats::interpolated);
  markPredictedBackwards(outcome);

  if (outcome.found_in_other_map && loop_closer_) {
    // Before the keyframe reaches loop closing (below, or through local mapping).
    const tracking::FoundInOtherMap& found = *outcome.found_in_other_map;
    loop::LoopMatch match;
    match.current = found.keyframe;
    match.loop = found.other_reference;
    match.T_w_c_corrected = found.T_wother_c;
    match.matched_points = found.other_points;
    match.ransac_inliers = match.inliers = found.inliers;
    loop_closer_->suggestMerge(match);
  }
  if (outcome.new_keyframe != nullptr) {
    stats.keyframe = true;
    // Its mask was another frame's, carried forward (or none had come yet): ask for its own.
    if (semantic_ && carriesMasks() && options_.semantic.keyframe_exact_mask && stats.mask_age != 0) {
      semantic_->requestOwnMask(frame_id, shared_bgr, image_name);
      std::lock_guard lock(keyframe_mask_mutex_);
      ++keyframe_masks_.requested;
    }
    if (dense_) pushDenseKeyframe(outcome.new_keyframe, frame, bgr, last_labels_);
    if (mapping_thread_) {
      // Offline: mapping may run behind by one keyframe at most, so that tracking always has the
      // map of the keyframe before last (unpaced input would otherwise outrun it). Real time:
      // never wait; the bounded queue absorbs bursts.
      if (!settings_.realtime) mapping_thread_->waitUntilIdle();
      mapping_thread_->push(outcome.new_keyframe);
    }
    else {
      applyKeyframeMask(outcome.new_keyframe);
      mapper_.process(outcome.new_keyframe, nullptr);
      if (settings_.after_local_mapping) settings_.after_local_mapping(outcome.new_keyframe->id);
      if (loop_closer_) loop_closer_->process(outcome.new_keyframe);
    }
  }
  if (!settings_.debug_images_dir.empty()) {
    const std::filesystem::path path = settings_.debug_images_dir / image_name;
    const cv::Mat view = drawDynamicDebugView(bgr, frame.dynamic_mask, frame);
    writeFileAtomicallyVia(path, "debug image", [&](const std::filesystem::path& tmp) { return cv::imwrite(tmp.string(), view); });
  }
  updateOdometry(frame_id);
  stats.total_ms = millisecondsSince(start);
  previous_processing_ms_ = stats.total_ms - stats.mask_wait_ms;
  frames_.push_back(stats);
  rethrowWorkerFailure();
}

void SlamSystem::updateOdometry(uint64_t frame_id) {
  last_T_odom_c_.reset();
  if (tracker_.records().empty()) return;
  const tracking::FrameRecord& now = tracker_.records().back();
  if (now.frame_id != frame_id || now.reference == nullptr) return;
  std::optional<SE3> T_prev_now;
  SE3 T_w_c_now;
  {
    std::shared_lock lock(map_.mutex());
    const SE3 T_c_w_now = now.T_c_r * map::keyframeTcw(now.reference);
    T_w_c_now = T_c_w_now.inverse();
    // Both frames' reference keyframes in one world now (after any merge), with their poses as they
    // are now: the motion tracking measured (or predicted) between the two, a correction of both
    // left out. From a predicted frame to a tracked one the step is extrapolated instead: the
    // prediction was a guess, and the frame found again would jump by its error (the map's pose
    // does; T_w_odom takes it up).
    const tracking::FrameRecord* last = odometry_last_ ? &*odometry_last_ : nullptr;
    const bool found_again =
        last != nullptr && last->source == tracking::PoseSource::kPredicted && now.source == tracking::PoseSource::kTracked;
    if (last != nullptr && !found_again && last->reference->map_id == now.reference->map_id)
      T_prev_now = last->T_c_r * map::keyframeTcw(last->reference) * T_w_c_now;
  }
  last_T_odom_c_ = odometry_.add(now.timestamp, T_prev_now, T_w_c_now);
  odometry_maps_.push_back(now.map_id);
  odometry_last_ = now;
}

AtlasTrajectory SlamSystem::odometryTrajectory() const {
  AtlasTrajectory trajectory;
  const Trajectory& poses = odometry_.poses();
  for (size_t i = 0; i < poses.size(); ++i)
    trajectory.push_back({poses[i].timestamp, poses[i].T_w_c, odometry_maps_[i], -1});
  return trajectory;
}

void SlamSystem::markPredictedBackwards(const tracking::TrackOutcome& outcome) {
  for (uint64_t id : outcome.predicted_backwards)
    if (id < frames_.size()) {  // frames_[i] is frame i's
      frames_[id].predicted_backwards = true;
      frames_[id].map = outcome.predicted_backwards_map;
    }
}

void SlamSystem::applyKeyframeMask(map::Keyframe* kf) {
  if (!semantic_) return;
  const auto wait_start = std::chrono::steady_clock::now();
  const std::shared_ptr<const semantic::Segmentation> own = semantic_->waitForOwnMask(kf->frame_id);
  if (own == nullptr) return;  // not requested (its mask was its own), or the run is stopping
  const double wait_ms = millisecondsSince(wait_start);
  // The same exclusion as at the keyframe's creation (tracking: the mask dilated, then the mapping
  // margin), now with the keyframe's own mask and no growth for age.
  const DynamicOptions& d = options_.dynamic;
  std::vector<uint8_t> in_mask;
  if (!own->dynamic_mask.empty() && cv::countNonZero(own->dynamic_mask) > 0)
    in_mask = dynamic::featuresInMask(*kf->features,
                                      dynamic::dilateMask(own->dynamic_mask, d.mask_dilation_px + d.mapping_margin_px));
  int features_removed = 0, points_removed = 0;
  if (!in_mask.empty()) {
    std::unique_lock lock(map_.mutex());
    for (size_t i = 0; i < in_mask.size(); ++i) {
      if (!in_mask[i] || kf->status[i] != map::FeatureStatus::kStatic) continue;
      kf->status[i] = map::FeatureStatus::kDynamicMask;
      ++features_removed;
      if (map::MapPoint* p = kf->points[i]) {
        map::eraseObservation(map_, p, kf);  // a point only this keyframe held goes with it
        points_removed += p->bad ? 1 : 0;
      }
    }
  }
  std::lock_guard lock(keyframe_mask_mutex_);
  ++keyframe_masks_.applied;
  keyframe_masks_.features_removed += features_removed;
  keyframe_masks_.points_removed += points_removed;
  keyframe_masks_.wait_ms.push_back(wait_ms);
}

void SlamSystem::pushDenseKeyframe(const map::Keyframe* kf, const map::Frame& frame, const cv::Mat& bgr,
                                   const cv::Mat& labels) {
  auto dense_kf = std::make_shared<dense::DenseKeyframe>();
  dense_kf->keyframe_id = kf->id;
  dense_kf->timestamp = frame.timestamp;
  dense_kf->bgr = bgr.clone();  // the message owns its pixels (see processFrame)
  dense_kf->depth = frame.depth.clone();
  dense_kf->labels = labels.clone();
  dense_kf->T_w_c = frame.T_c_w.inverse();
  // Left out of the dense map: the semantic mask (semantic/full) and the surroundings of every
  // feature the depth checks found dynamic.
  cv::Mat exclude = frame.dynamic_mask.empty() ? cv::Mat::zeros(bgr.size(), CV_8U) : frame.dynamic_mask.clone();
  for (size_t i = 0; i < frame.status.size(); ++i) {
    if (frame.status[i] == map::FeatureStatus::kDynamicStage1 || frame.status[i] == map::FeatureStatus::kDynamicStage2)
      cv::circle(exclude, frame.features->keypoints[i].pt, kDynamicFeatureRadius, cv::Scalar(255), cv::FILLED);
  }
  dense_kf->exclude_mask = exclude;
  // Newest poses of every keyframe so far (culled ones follow their parent): the dense map
  // merges the new keyframe's points into voxels anchored at older keyframes with the poses
  // local BA has refined. Cheap here: the dense thread applies them itself.
  dense::PoseMap poses;
  std::vector<std::shared_ptr<dense::DenseKeyframe>> ready;  // into the dense map now
  {
    std::shared_lock lock(map_.mutex());
    for (const map::Keyframe* other : map_.allKeyframes())
      if (other != kf) poses.emplace(other->id, map::keyframeTcw(other).inverse());
    // The dense map has one world: that of the map its first keyframe came from. Keyframes of
    // other maps wait until a merge brings their map into that world (merges relabel map_id).
    if (dense_world_map_ < 0) dense_world_map_ = kf->map_id;
    const int world = map_.liveMap(dense_world_map_);
    dense_held_.push_back({kf, std::move(dense_kf)});
    releaseHeldDenseKeyframes(world, ready);
    while (dense_held_.size() > kMaxHeldDenseKeyframes) {  // bounded memory: the oldest go
      dense_held_.erase(dense_held_.begin());
      ++dense_held_dropped_;
    }
  }
  dense_->updatePoses(poses);
  for (auto& k : ready) dense_->push(std::move(k));
}

void SlamSystem::releaseHeldDenseKeyframes(int world, std::vector<std::shared_ptr<dense::DenseKeyframe>>& ready) {
  for (auto it = dense_held_.begin(); it != dense_held_.end();) {
    if (it->first->map_id != world) {
      ++it;
      continue;
    }
    it->second->T_w_c = map::keyframeTcw(it->first).inverse();
    ready.push_back(std::move(it->second));
    it = dense_held_.erase(it);
  }
}

void SlamSystem::finish(const FinishControl& control) {
  if (finished_) return;
  finished_ = true;
  const auto stage = [&control](const char* name) { return !control.on_stage || control.on_stage(name); };
  const auto aborted = [&control] { return control.abort != nullptr && control.abort->load(); };
  stage("mapping");
  // Local mapping may still wait for keyframes' own masks: the network stops after it (at once
  // when the run is being cut short).
  if (semantic_ && aborted()) semantic_->stop();
  if (mapping_thread_) mapping_thread_->stop();
  if (semantic_) semantic_->stop();
  if (loop_thread_) loop_thread_->stop(control.abort);  // drains its queue and waits for a global BA
  if (loop_closer_ && !loop_closer_->waitForGlobalBa(control.abort)) loop_closer_->abortGlobalBa();
  const bool worker_failed = [this] {
    return (mapping_thread_ && mapping_thread_->failure()) || (loop_thread_ && loop_thread_->failure()) ||
           (loop_closer_ && loop_closer_->failure());
  }();
  // Maps still apart may find each other now that every keyframe is in (atlas.final_merge_search).
  if (loop_closer_ && !worker_failed && !aborted()) {
    const int merged = loop_closer_->mergeRemainingMaps(control.abort);
    if (merged > 0) spdlog::info("finish: {} more map merge(s) at the end of the run", merged);
  }
  // After a failed worker the map may be half-updated: no final BA on it.
  if (options_.mapping.final_global_ba && !worker_failed && stage("final_ba") && !aborted()) {
    optim::BundleAdjustmentOptions ba;
    ba.bf = camera_.bf();
    ba.iterations = options_.mapping.global_ba_iterations;
    ba.threads = 2;  // nothing else runs now but the dense thread finishing its queue
    final_ba_ = optim::globalBundleAdjustment(map_, camera_, ba, control.abort);
  }
  // Frames still waiting for the motion after their loss (the run ended within
  // kBridgeVelocityFrames frames of it) get what there is.
  tracking::TrackOutcome last_outcome;
  tracker_.finishBackwardPrediction(last_outcome);
  markPredictedBackwards(last_outcome);
  // All merges are done: frames without a pose between two with one that ended in one map get
  // poses between those (tracking::Tracker::interpolateAcrossMerges).
  const std::vector<tracking::FrameRecord> interpolated = tracker_.interpolateAcrossMerges();
  for (const tracking::FrameRecord& r : interpolated)
    if (r.frame_id < frames_.size()) {  // frames_[i] is frame i's
      frames_[r.frame_id].interpolated = true;
      frames_[r.frame_id].map = r.map_id;
    }
  if (!interpolated.empty())
    spdlog::debug("finish: {} frames interpolated between poses that merges brought into one map",
                  interpolated.size());
  // Then the frames still without a pose get the nearer frame's (tracking::Tracker::holdNearestPoses).
  const std::vector<tracking::FrameRecord> held = tracker_.holdNearestPoses();
  for (const tracking::FrameRecord& r : held)
    if (r.frame_id < frames_.size()) {
      FrameStats& f = frames_[r.frame_id];
      f.held = true;
      f.predicted = r.source == tracking::PoseSource::kPredicted;
      f.predicted_backwards = r.source == tracking::PoseSource::kPredictedBackwards;
      f.map = r.map_id;
    }
  if (!held.empty())
    spdlog::info("finish: {} frames without a pose given the nearer frame's pose (tracking.hold_pose_s)", held.size());
  // Keyframes held for a map that a merge at the end of the run brought into the dense map's world:
  // no later keyframe hands them on (pushDenseKeyframe does that while the run goes on).
  if (dense_ && dense_world_map_ >= 0 && !dense_held_.empty()) {
    std::vector<std::shared_ptr<dense::DenseKeyframe>> ready;
    {
      std::shared_lock lock(map_.mutex());
      releaseHeldDenseKeyframes(map_.liveMap(dense_world_map_), ready);
    }
    for (auto& k : ready) dense_->push(std::move(k));
  }
  stage("dense");
  if (dense_) dense_->waitUntilIdle();
  rethrowWorkerFailure();
}

std::map<int, size_t> SlamSystem::framesPerMapLocked() const {
  std::map<int, size_t> frames_per_map;
  for (const tracking::FrameRecord& r : tracker_.records())
    if (r.reference != nullptr) ++frames_per_map[r.reference->map_id];
  return frames_per_map;
}

int SlamSystem::mainMapLocked() const { return mainMapOf(framesPerMapLocked()); }

int SlamSystem::mainMapOf(const std::map<int, size_t>& frames_per_map) {
  int best = -1;
  size_t most = 0;
  for (const auto& [id, n] : frames_per_map)  // by id: the older map wins a tie
    if (n > most) {
      most = n;
      best = id;
    }
  return best;
}

Trajectory SlamSystem::cameraTrajectory() const {
  Trajectory trajectory;
  std::shared_lock lock(map_.mutex());
  const int main_map = mainMapLocked();
  for (const tracking::FrameRecord& r : tracker_.records()) {
    if (r.reference == nullptr || r.reference->map_id != main_map) continue;
    const SE3 T_c_w = r.T_c_r * map::keyframeTcw(r.reference);
    trajectory.push_back({r.timestamp, T_c_w.inverse()});
  }
  return trajectory;
}

AtlasTrajectory SlamSystem::cameraTrajectoryAll() const {
  AtlasTrajectory trajectory;
  std::shared_lock lock(map_.mutex());
  for (const tracking::FrameRecord& r : tracker_.records()) {
    if (r.reference == nullptr) continue;
    const SE3 T_c_w = r.T_c_r * map::keyframeTcw(r.reference);
    trajectory.push_back({r.timestamp, T_c_w.inverse(), r.map_id, r.reference->map_id});
  }
  return trajectory;
}

AtlasTrajectory SlamSystem::keyframeTrajectoryAll() const {
  AtlasTrajectory trajectory;
  std::shared_lock lock(map_.mutex());
  for (const map::Keyframe* kf : map_.keyframes())
    trajectory.push_back({kf->timestamp, kf->T_w_c(), kf->map_id, kf->map_id});
  return trajectory;
}

int SlamSystem::mainMap() const {
  std::shared_lock lock(map_.mutex());
  return mainMapLocked();
}

std::optional<AtlasPose> SlamSystem::lastFramePose() const {
  if (tracker_.records().empty() || next_frame_id_ == 0) return std::nullopt;
  const tracking::FrameRecord& r = tracker_.records().back();
  if (r.frame_id != next_frame_id_ - 1 || r.reference == nullptr) return std::nullopt;
  std::shared_lock lock(map_.mutex());
  const SE3 T_c_w = r.T_c_r * map::keyframeTcw(r.reference);
  return AtlasPose{r.timestamp, T_c_w.inverse(), r.map_id, r.reference->map_id};
}

nlohmann::json SlamSystem::atlasJson() const {
  std::map<int, size_t> frames_tracked_in;
  std::map<int, std::pair<double, double>> span;  // first and last frame time per map it was tracked in
  for (const tracking::FrameRecord& r : tracker_.records()) {
    if (r.reference == nullptr) continue;
    ++frames_tracked_in[r.map_id];
    auto [it, inserted] = span.emplace(r.map_id, std::make_pair(r.timestamp, r.timestamp));
    if (!inserted) it->second.second = r.timestamp;
  }
  std::shared_lock lock(map_.mutex());
  nlohmann::json maps = nlohmann::json::array();
  int merges = 0;
  for (const map::MapRecord& m : map_.mapRecords()) {
    nlohmann::json entry = {{"id", m.id},
                            {"reason", m.reason},
                            {"first_frame", m.first_frame_id},
                            {"start_time", m.start_time},
                            {"frames", frames_tracked_in[m.id]},
                            {"keyframes", map_.keyframeCount(m.id)},
                            {"live", m.merged_into < 0},
                            {"merged_into", m.merged_into >= 0 ? nlohmann::json(m.merged_into) : nlohmann::json(nullptr)}};
    if (auto it = span.find(m.id); it != span.end())
      entry["time_span"] = {it->second.first, it->second.second};
    if (m.merged_into >= 0) {
      ++merges;
      const Quat& q = m.T_into_this.quaternion();
      const Vec3& t = m.T_into_this.translation();
      entry["merged_at"] = m.merged_at;
      // T_w(into)_w(this), TUM order: tx ty tz qx qy qz qw.
      entry["T_into_this"] = {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
    }
    maps.push_back(entry);
  }
  std::map<int, size_t> frames_in_world = framesPerMapLocked();
  const int main_map = mainMapOf(frames_in_world);
  size_t outside_main = 0;
  nlohmann::json apart = nlohmann::json::array();
  for (const auto& [id, n] : frames_in_world)
    if (id != main_map) {
      outside_main += n;
      apart.push_back({{"id", id}, {"frames", n}});
    }
  return {{"maps", maps},
          {"maps_started", tracker_.mapsStarted()},
          {"merges", merges},
          {"main_map", main_map},
          {"frames_in_main_map", frames_in_world[main_map]},
          // Frames with a pose only in maps never merged into the main map: not in
          // CameraTrajectory.txt nor in its ATE (CameraTrajectory_all.txt has them, each in its map's frame).
          {"frames_outside_main_map", outside_main},
          {"maps_apart_from_main", apart},
          {"initialisations_refused", tracker_.initialisationsRefused()}};
}

Trajectory SlamSystem::keyframeTrajectory() const {
  Trajectory trajectory;
  std::shared_lock lock(map_.mutex());
  for (const map::Keyframe* kf : map_.keyframes()) trajectory.push_back({kf->timestamp, kf->T_w_c()});
  return trajectory;
}

namespace {
nlohmann::json closedLoopsJson(const std::vector<loop::ClosedLoop>& loops) {
  nlohmann::json list = nlohmann::json::array();
  for (const loop::ClosedLoop& l : loops)
    list.push_back({{"current_keyframe", l.current_keyframe}, {"loop_keyframe", l.loop_keyframe},
                    {"current_timestamp", l.current_timestamp}, {"loop_timestamp", l.loop_timestamp},
                    {"inliers", l.inliers}, {"correction_m", l.correction_m}, {"correction_deg", l.correction_deg}});
  return list;
}
}  // namespace

nlohmann::json SlamSystem::statistics() const {
  std::vector<double> extraction, tracking, tracking_thread, total, mask_wait, segmentation;
  nlohmann::json per_frame = nlohmann::json::array();
  long in_mask = 0, semantic_removed = 0, stage1_checked = 0, stage1_removed = 0, stage2_removed = 0, added = 0, free_space = 0,
       map_verified = 0;
  size_t fresh_masks = 0, carried_masks = 0, no_mask = 0;
  for (const FrameStats& f : frames_) {
    extraction.push_back(f.extraction_ms);
    tracking.push_back(f.tracking_ms);
    // The per-frame cost on the tracking thread: extraction and pose estimation, not waiting.
    tracking_thread.push_back(f.extraction_ms + f.tracking_ms);
    total.push_back(f.total_ms);
    mask_wait.push_back(f.mask_wait_ms);
    if (f.segmentation_ms >= 0) segmentation.push_back(f.segmentation_ms);
    in_mask += f.in_mask;
    semantic_removed += f.semantic_removed;
    stage1_checked += f.stage1_checked;
    stage1_removed += f.stage1_removed;
    stage2_removed += f.stage2_removed;
    added += f.features_added_outside_mask;
    free_space += f.free_space_removed;
    map_verified += f.map_verified;
    if (f.mask_age == 0) ++fresh_masks;
    else if (f.mask_age > 0) ++carried_masks;
    else ++no_mask;
    per_frame.push_back({{"features", f.features}, {"in_mask", f.in_mask}, {"semantic_removed", f.semantic_removed},
                         {"stage1_checked", f.stage1_checked}, {"stage1_removed", f.stage1_removed},
                         {"stage2_removed", f.stage2_removed}, {"mask_age", f.mask_age}, {"mask_radius_px", f.mask_radius_px},
                         {"features_added_outside_mask", f.features_added_outside_mask},
                         {"free_space_removed", f.free_space_removed}, {"stage1_map_verified", f.map_verified},
                         {"fresh_mask", f.mask_age == 0}, {"own_mask_waited", f.own_mask_waited},
                         {"segmentation_ms", f.segmentation_ms},
                         {"tracking_ms", f.extraction_ms + f.tracking_ms}, {"extraction_ms", f.extraction_ms},
                         {"pose_tracking_ms", f.tracking_ms}, {"mask_wait_ms", f.mask_wait_ms},
                         {"total_ms", f.total_ms}, {"tracked", f.tracked},
                         {"keyframe", f.keyframe}, {"inliers", f.inliers}, {"motion_model", f.motion_model},
                         {"timestamp", f.timestamp}, {"map", f.map}, {"new_map", f.new_map},
                         {"features_with_depth", f.features_with_depth},
                         {"static_with_depth", f.static_with_depth},
                         {"weak", f.weak}, {"odometry", f.odometry},
                         {"depth_odometry", f.depth_odometry}, {"predicted", f.predicted},
                         {"backfilled", f.backfilled},
                         {"interpolated", f.interpolated}, {"predicted_backwards", f.predicted_backwards},
                         {"held", f.held}});
    if (f.reloc_candidates >= 0)
      per_frame.back()["relocalisation"] = {{"candidates", f.reloc_candidates}, {"best_matches", f.reloc_matches},
                                            {"best_pnp_inliers", f.reloc_pnp_inliers},
                                            {"best_inliers", f.reloc_inliers}};
  }
  size_t with_pose = 0, tracked = 0;
  for (const auto& r : tracker_.records())
    if (r.reference != nullptr) ++with_pose;
  for (const FrameStats& f : frames_) tracked += f.tracked;
  nlohmann::json j;
  {
    std::shared_lock lock(map_.mutex());
    j["counts"] = {{"frames", frames_.size()},
                   {"frames_tracked", tracked},      // by features, in any map
                   {"frames_with_pose", with_pose},  // tracked or predicted, in any map
                   {"frames_lost", tracker_.lostFrames()},
                   {"tracking_losses", tracker_.losses()},
                   {"relocalisations", tracker_.relocalisations()},
                   {"found_in_other_map", tracker_.foundInOtherMap()},
                   {"implausible_jumps_refused", tracker_.implausibleJumps()},
                   {"bridge_disagreements_refused", tracker_.bridgeDisagreements()},
                   {"bridge_overruled", tracker_.bridgeOverruled()},
                   {"weak_poses", tracker_.weakPoses()},
                   {"odometry_poses", tracker_.odometryPoses()},
                   {"depth_odometry_poses", tracker_.depthOdometryPoses()},
                   {"predicted_by_odometry", tracker_.predictedByOdometry()},
                   {"predicted_poses", tracker_.predictedPoses()},
                   {"backfilled_poses", tracker_.backfilledPoses()},
                   {"interpolated_poses", tracker_.interpolatedPoses()},
                   {"backward_predicted_poses", tracker_.backwardPredictedPoses()},
                   {"held_poses", tracker_.heldPoses()},
                   // The odometry frame (odometry_chain.hpp): frames in it, and steps where the last
                   // velocity was extrapolated (between worlds no merge had joined, or from a
                   // predicted frame to one found again).
                   {"odometry_frame_poses", odometry_.poses().size()},
                   {"odometry_frame_extrapolated_steps", odometry_.extrapolatedSteps()},
                   {"keyframes", map_.keyframeCount()},
                   {"keyframes_created", map_.allKeyframes().size()},
                   {"map_points", map_.pointCount()}};
  }
  j["atlas"] = atlasJson();
  j["dynamic"] = {{"mode", nameOf(options_.dynamic.mode)},
                  {"features_in_mask", in_mask},
                  {"features_added_outside_mask", added},
                  {"removed_by_mask", semantic_removed},
                  {"stage1_checked", stage1_checked},
                  {"removed_stage1", stage1_removed},
                  {"removed_stage1_free_space", free_space},
                  {"stage1_map_verified", map_verified},
                  {"removed_stage2", stage2_removed},
                  {"frames_with_fresh_mask", fresh_masks},
                  {"frames_with_carried_mask", carried_masks},
                  {"frames_without_mask", no_mask}};
  const auto& ms = mapper_.stats();
  j["local_mapping"] = {{"keyframes_processed", ms.keyframes_processed},
                        {"points_triangulated", ms.points_triangulated},
                        {"recent_points_culled", ms.points_culled},
                        {"keyframes_culled", ms.keyframes_culled},
                        {"ba_runs", ms.ba_runs},
                        {"ba_aborted", ms.ba_aborted},
                        {"weak_keyframes_held", ms.weak_keyframes_held},
                        {"keyframes_held_moved_far", ms.keyframes_held_moved_far},
                        {"timings_ms",
                         {{"insert", summarizeMilliseconds(ms.insert_ms)},
                          {"cull_points", summarizeMilliseconds(ms.cull_points_ms)},
                          {"triangulate", summarizeMilliseconds(ms.triangulate_ms)},
                          {"fuse", summarizeMilliseconds(ms.fuse_ms)},
                          {"local_ba", summarizeMilliseconds(ms.ba_ms)},
                          {"cull_keyframes", summarizeMilliseconds(ms.cull_keyframes_ms)},
                          {"per_keyframe", summarizeMilliseconds(ms.total_ms)}}}};
  if (loop_closer_) {
    const loop::LoopClosingStats ls = loop_closer_->stats();
    j["loop_closing"] = {{"keyframes_checked", ls.detection.keyframes_checked},
                         {"consistent_candidates", ls.detection.consistent_candidates},
                         {"rejected_by_geometry", ls.detection.rejected_geometry},
                         {"rejected_by_confirmation", ls.detection.rejected_confirmation},
                         {"loops_detected", ls.loops_detected},
                         {"loops_closed", ls.loops_closed},
                         {"merges_detected", ls.detection.merges_detected},
                         {"merge_evidence", ls.detection.merge_evidence},
                         {"merges_by_agreement", ls.detection.merges_by_agreement},
                         {"merges_at_end", ls.merges_at_end},
                         {"merges_found_by_tracking",
                          std::count_if(ls.merges.begin(), ls.merges.end(),
                                        [](const loop::MergedMaps& m) { return m.found_by_tracking; })},
                         {"loops_skipped", ls.loops_skipped},
                         {"points_fused", ls.points_fused},
                         {"global_ba_runs", ls.global_ba_runs},
                         {"global_ba_applied", ls.global_ba_applied},
                         {"global_ba_aborted", ls.global_ba_aborted},
                         {"weak_keyframes_held", ls.weak_keyframes_held},
                         {"loose_groups_held", ls.loose_groups_held},
                         {"keyframes_dropped", loop_thread_ ? loop_thread_->dropped() : 0},
                         {"closed", closedLoopsJson(ls.closed)},
                         {"timings_ms",
                          {{"correction", summarizeMilliseconds(ls.correction_ms)},
                           {"pose_graph", summarizeMilliseconds(ls.pose_graph_ms)},
                           {"global_ba", summarizeMilliseconds(ls.global_ba_ms)}}}};
  }
  if (options_.mapping.final_global_ba)
    j["final_global_ba"] = {{"keyframes", final_ba_.keyframes}, {"points", final_ba_.points},
                            {"observations", final_ba_.observations}, {"outliers", final_ba_.outliers},
                            {"completed", final_ba_.completed},
                            {"weak_keyframes_held", final_ba_.weak_keyframes_held},
                            {"loose_groups_held", final_ba_.loose_groups_held}, {"seconds", final_ba_.seconds}};
  j["timings_ms"] = {{"orb_extraction", summarizeMilliseconds(extraction)},
                     {"mask_wait", summarizeMilliseconds(mask_wait)},
                     {"segmentation", summarizeMilliseconds(segmentation)},
                     {"pose_tracking", summarizeMilliseconds(tracking)},
                     {"tracking", summarizeMilliseconds(tracking_thread)},
                     {"frame_total", summarizeMilliseconds(total)}};
  if (semantic_) {
    // How old the masks tracking used were: frames per age (0 = its own), "10+" and "none".
    nlohmann::json ages = nlohmann::json::object();
    for (const FrameStats& f : frames_) {
      const std::string key = f.mask_age < 0 ? "none" : (f.mask_age >= 10 ? "10+" : std::to_string(f.mask_age));
      ages[key] = ages.value(key, 0) + 1;
    }
    j["semantic"] = {{"segmented", semantic_->segmentedCount()},
                     {"dropped", semantic_->droppedCount()},
                     {"mask_age_frames", ages}};
    std::lock_guard lock(keyframe_mask_mutex_);
    // Own masks: keyframes' (before local mapping) and lost frames' (semantic.own_mask_when_lost).
    j["semantic"]["own_mask_requests"] = semantic_->ownMaskRequestCount();
    j["semantic"]["own_mask_segmentations"] = semantic_->ownMaskSegmentationCount();  // frames the stream had dropped
    j["semantic"]["keyframe_own_masks"] = {{"requested", keyframe_masks_.requested},
                                           {"applied", keyframe_masks_.applied},
                                           {"features_removed", keyframe_masks_.features_removed},
                                           {"points_removed", keyframe_masks_.points_removed},
                                           {"wait_ms", summarizeMilliseconds(keyframe_masks_.wait_ms)}};
  }
  j["mode"] = settings_.deterministic ? "deterministic" : (settings_.realtime ? "realtime" : "offline");
  j["per_frame"] = std::move(per_frame);
  return j;
}

nlohmann::json SlamSystem::exportDenseMap(const std::filesystem::path& out_dir, bool semantic_colour,
                                          const std::atomic<bool>* abort,
                                          const std::function<void(const std::string& file, double share)>& on_progress) const {
  if (!dense_) return {{"enabled", false}};
  const auto aborted = [abort] { return abort != nullptr && abort->load(); };
  if (aborted())
    return {{"enabled", true}, {"exported", false}, {"note", "skipped: the run was interrupted twice"}};
  const auto start = std::chrono::steady_clock::now();
  const size_t peak_before_export = dense::peakResidentBytes();
  dense::PoseMap poses;
  std::vector<SE3> camera_path;
  int main_map = -1, world = -1;
  {
    std::shared_lock lock(map_.mutex());
    main_map = mainMapLocked();
    world = dense_world_map_ < 0 ? -1 : map_.liveMap(dense_world_map_);
    if (main_map < 0) main_map = world;
    for (const map::Keyframe* kf : map_.allKeyframes()) poses[kf->id] = map::keyframeTcw(kf).inverse();
    for (const map::Keyframe* kf : map_.keyframes())
      if (kf->map_id == main_map) camera_path.push_back(kf->T_w_c());
  }
  // The dense map follows the main map (the trajectory's): when that is not the dense map's world
  // (an unmerged map outgrew it), its held keyframes are mapped now, in a dense map of their own.
  std::unique_ptr<dense::DenseMappingThread> main_dense;
  if (main_map != world) {
    main_dense = std::make_unique<dense::DenseMappingThread>(options_.dense, camera_, QueueFullPolicy::kBlock);
    std::shared_lock lock(map_.mutex());
    for (const auto& [keyframe, held] : dense_held_) {
      if (keyframe->map_id != main_map) continue;
      auto copy = std::make_shared<dense::DenseKeyframe>(*held);
      copy->T_w_c = poses.at(copy->keyframe_id);
      main_dense->push(std::move(copy));
    }
  }
  if (main_dense) main_dense->waitUntilIdle();
  const dense::DenseMappingThread* dense = main_dense ? main_dense.get() : dense_.get();
  dense_->updatePoses(poses);
  if (main_dense) main_dense->updatePoses(poses);
  const dense::DenseCloud exported = dense->exportCloud(poses);
  const double cloud_ms = millisecondsSince(start);
  const std::shared_ptr<open3d::geometry::PointCloud> cloud = dense::toOpen3d(exported, semantic_colour);
  const dense::DenseMapStats stats = dense->mapStats();
  if (cloud->points_.empty())
    return {{"enabled", true},
            {"exported", false},
            {"keyframes", stats.keyframes},
            {"map_points", 0},
            {"note", "the dense map is empty (" + std::to_string(stats.keyframes) +
                         " keyframes mapped): no dense map files written"}};
  // The point cloud, its PCD copy and the sidecar are one set (mapcheck reads them together);
  // the OctoMap and the PNG follow, each skipped once the run is interrupted a second time.
  nlohmann::json files = nlohmann::json::array(), skipped = nlohmann::json::array(),
                 warnings = nlohmann::json::array(), octomap = nlohmann::json::object();
  dense::writePly(out_dir / "dense_map.ply", *cloud);
  dense::writePcd(out_dir / "dense_map.pcd", *cloud);
  dense::writeMapSources(out_dir / "dense_map_sources.bin", exported.first_seen);
  files = {"dense_map.ply", "dense_map.pcd", "dense_map_sources.bin"};
  double octomap_ms = 0;
  if (aborted()) {
    skipped.push_back("octomap.bt");
  } else {
    const auto octomap_start = std::chrono::steady_clock::now();
    const std::vector<dense::WorldScan> scans = dense->worldScans(poses);
    // Bounded before it starts: a resolution that would give too large a tree is coarsened.
    const DenseOptions& o = options_.dense;
    const double resolution =
        dense::boundedOctomapResolution(scans, o.octomap_resolution, o.max_depth, o.octomap_max_cells);
    const dense::OctomapCost cost = dense::octomapCost(scans, resolution, o.max_depth);
    octomap = {{"resolution", resolution}, {"rays", cost.rays}, {"ray_cells", cost.ray_cells},
               {"cells_estimated", cost.cells()}};
    if (resolution != o.octomap_resolution) {
      const dense::OctomapCost asked = dense::octomapCost(scans, o.octomap_resolution, o.max_depth);
      char text[640];
      std::snprintf(text, sizeof text,
                    "dense.octomap_resolution = %g m would give an OctoMap of about %.2g cells (%zu rays, keyframes: "
                    "%zu), more than dense.octomap_max_cells = %.2g: its time and memory grow as "
                    "1/resolution^3 (minutes and GiB from 1e8 cells on); octomap.bt is written at %g m instead "
                    "(about %.2g cells); raise dense.octomap_max_cells to allow the finer one",
                    o.octomap_resolution, asked.cells(), asked.rays, scans.size(), o.octomap_max_cells, resolution,
                    cost.cells());
      warnings.push_back(text);
      octomap["resolution_configured"] = o.octomap_resolution;
      octomap["cells_estimated_configured"] = asked.cells();
    }
    const bool written = dense::writeOctomap(out_dir / "octomap.bt", scans, resolution, o.max_depth, abort,
                                             [&on_progress](double share) {
                                               if (on_progress) on_progress("octomap.bt", share);
                                             });
    octomap_ms = millisecondsSince(octomap_start);
    (written ? files : skipped).push_back("octomap.bt");
  }
  if (aborted()) {
    skipped.push_back("dense_map.png");
  } else {
    dense::RenderSettings render;
    render.width = options_.dense.render_width;
    render.height = options_.dense.render_height;
    render.point_size = options_.dense.voxel_size;
    dense::renderPng(out_dir / "dense_map.png", *cloud, camera_path, render);
    files.push_back("dense_map.png");
  }
  // The free-space-violation share needs the keyframes' depth images, which the dense thread
  // does not keep (that is what bounds its memory): `desslam mapcheck` computes it.
  return {{"enabled", true},
          {"exported", true},
          {"files", files},
          {"skipped", skipped},
          {"warnings", warnings},
          {"octomap", octomap},
          {"keyframes", stats.keyframes},
          {"keyframes_culled", stats.culled},
          {"stored_voxels", stats.voxels},
          {"map_points", cloud->points_.size()},
          {"voxels", stats.voxels},
          {"rekeys", stats.rekeys},
          {"voxels_rekeyed", stats.voxels_rekeyed},
          {"voxels_merged_by_rekey", stats.voxels_merged},
          {"carve_free_space", options_.dense.carve_free_space},
          {"voxel_misses_by_carving", stats.voxel_misses},
          {"thread_ms_per_keyframe", summarizeMilliseconds(dense->keyframeMilliseconds())},
          {"thread_cpu_ms_per_keyframe", summarizeMilliseconds(dense->keyframeCpuMilliseconds())},
          {"peak_rss_mib", static_cast<double>(dense::peakResidentBytes()) / (1024.0 * 1024.0)},
          {"peak_rss_before_export_mib", static_cast<double>(peak_before_export) / (1024.0 * 1024.0)},
          {"export_cloud_ms", cloud_ms},
          {"export_octomap_ms", octomap_ms},
          {"export_ms", millisecondsSince(start)},
          {"sources_file", "dense_map_sources.bin"},
          {"map", main_map},
          {"keyframes_of_other_maps_left_out", dense_held_.size() + dense_held_dropped_}};
}

}  // namespace desslam::system
