#include "core/options.hpp"

#include <cmath>
#include <sstream>
#include <utility>

namespace desslam {

void requireInRange(const char* section, const char* key, double value, double lo, double hi) {
  if (std::isfinite(value) && value >= lo && value <= hi) return;  // NaN fails both comparisons too
  std::ostringstream msg;
  msg << "config key " << section << "." << key << " = " << value << " is out of range: expected "
      << lo << " <= value <= " << hi;
  throw ConfigError(msg.str());
}

void requireThat(bool ok, const char* section, const char* key, const std::string& message) {
  if (!ok) throw ConfigError(std::string("config key ") + section + "." + key + ": " + message);
}

void CameraOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "width", width, 16, 16384);
  requireInRange(s, "height", height, 16, 16384);
  // The focal length against the image size: a horizontal field of view outside 20-170 degrees is
  // no RGB-D camera (typically 55-90); fy must give nearly square pixels.
  constexpr double kMinFovDeg = 20.0, kMaxFovDeg = 170.0;
  const double fx_lo = width / (2.0 * std::tan(kMaxFovDeg * M_PI / 360.0));
  const double fx_hi = width / (2.0 * std::tan(kMinFovDeg * M_PI / 360.0));
  if (!(std::isfinite(fx) && fx >= fx_lo && fx <= fx_hi)) {
    std::ostringstream msg;
    msg << "config key camera.fx = " << fx << " (pixels) is implausible for an image " << width
        << " pixels wide: ";
    if (std::isfinite(fx) && fx > 0)
      msg << "it gives a horizontal field of view of " << 2.0 * std::atan(width / (2.0 * fx)) * 180.0 / M_PI
          << " degrees; ";
    msg << "expected " << kMinFovDeg << "-" << kMaxFovDeg << " degrees, i.e. " << fx_lo << " <= fx <= " << fx_hi
        << " (TUM/Bonn: fx ~ 517-542 for 640 pixels)";
    throw ConfigError(msg.str());
  }
  if (!(std::isfinite(fy) && fy >= 0.5 * fx && fy <= 2.0 * fx)) {
    std::ostringstream msg;
    msg << "config key camera.fy = " << fy << " is implausible with camera.fx = " << fx
        << ": expected 0.5 * fx <= fy <= 2 * fx (pixels are nearly square; fy is usually within 1 % of fx)";
    throw ConfigError(msg.str());
  }
  requireInRange(s, "cx", cx, 0, width);
  requireInRange(s, "cy", cy, 0, height);
  for (double k : distortion) requireInRange(s, "distortion", k, -1000.0, 1000.0);
  requireThat(std::isfinite(depth_factor) && depth_factor > 0, s, "depth_factor",
              "must be positive: raw depth units per metre (5000 for TUM and Bonn, 1000 for mm)");
  requireInRange(s, "depth_factor", depth_factor, 1.0, 1e6);
  requireInRange(s, "fps", fps, 0.1, 1000);
  requireInRange(s, "depth_baseline", depth_baseline, 0.001, 10.0);
}

void OrbOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "num_features", num_features, 50, 20000);
  requireInRange(s, "num_levels", num_levels, 1, 16);
  requireInRange(s, "scale_factor", scale_factor, 1.01, 2.0);
  requireInRange(s, "initial_fast_threshold", initial_fast_threshold, 1, 255);
  requireInRange(s, "min_fast_threshold", min_fast_threshold, 1, initial_fast_threshold);
  requireInRange(s, "cell_size", cell_size, 10, 200);
}

void TrackingOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "min_depth", min_depth, 0.0, 10.0);
  requireInRange(s, "max_depth", max_depth, min_depth, 100.0);
  requireInRange(s, "close_depth", close_depth, min_depth, max_depth);
  requireInRange(s, "min_inliers", min_inliers, 4, 1000);
  requireInRange(s, "max_speed_m_s", max_speed_m_s, 0.01, 1000.0);
  requireInRange(s, "max_acceleration_m_s2", max_acceleration_m_s2, 0.0, 1000.0);
  requireInRange(s, "max_frames_between_keyframes", max_frames_between_keyframes, 1, 100000);
  requireInRange(s, "min_frames_between_keyframes", min_frames_between_keyframes, 0,
                 max_frames_between_keyframes);
  requireInRange(s, "keyframe_tracked_ratio", keyframe_tracked_ratio, 0.0, 1.0);
  requireInRange(s, "keyframe_translation", keyframe_translation, 0.0, 100.0);
  requireInRange(s, "keyframe_rotation_deg", keyframe_rotation_deg, 0.0, 180.0);
  requireInRange(s, "keyframe_still_translation", keyframe_still_translation, 0.0, keyframe_translation);
  requireInRange(s, "keyframe_still_rotation_deg", keyframe_still_rotation_deg, 0.0, keyframe_rotation_deg);
  requireInRange(s, "local_map_keyframes", local_map_keyframes, 1, 1000);
  requireInRange(s, "predict_through_loss_s", predict_through_loss_s, 0.0, 5.0);
  requireInRange(s, "crowded_view_share", crowded_view_share, 0.0, 1.0);
  requireInRange(s, "crowded_keyframe_spacing", crowded_keyframe_spacing, 0, max_frames_between_keyframes);
}

void MatcherOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "max_distance", max_distance, 0, 256);
  requireInRange(s, "strict_distance", strict_distance, 0, max_distance);
  requireInRange(s, "ratio", ratio, 0.1, 1.0);
}

void MappingOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "covisible_for_triangulation", covisible_for_triangulation, 1, 100);
  requireInRange(s, "local_ba_iterations", local_ba_iterations, 1, 1000);
  requireInRange(s, "redundant_keyframe_ratio", redundant_keyframe_ratio, 0.0, 1.0);
  requireInRange(s, "global_ba_iterations", global_ba_iterations, 1, 1000);
}

void DynamicOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "stage1_threshold", stage1_threshold, 0.0, 10.0);
  requireInRange(s, "stage2_threshold", stage2_threshold, 0.0, 10.0);
  requireInRange(s, "mask_dilation_px", mask_dilation_px, 0, 100);
  requireInRange(s, "carried_mask_growth_px", carried_mask_growth_px, 0, 100);
  requireInRange(s, "carried_mask_max_growth_px", carried_mask_max_growth_px, 0, 300);
  requireInRange(s, "carried_mask_min_outside_share", carried_mask_min_outside_share, 0.0, 1.0);
  requireInRange(s, "mapping_margin_px", mapping_margin_px, 0, 300);
  requireInRange(s, "stage1_search_radius_px", stage1_search_radius_px, 1.0, 200.0);
  requireInRange(s, "stage1_max_descriptor_distance", stage1_max_descriptor_distance, 0, 256);
  requireInRange(s, "stage1_match_ratio", stage1_match_ratio, 0.1, 1.0);
  requireInRange(s, "stage2_keyframes", stage2_keyframes, 1, 50);
  requireInRange(s, "stage1_min_interval_s", stage1_min_interval_s, 0.0, 10.0);
  requireInRange(s, "stage1_max_reprojection_px", stage1_max_reprojection_px, 0.1, 1000.0);
  requireInRange(s, "min_features_outside_mask", min_features_outside_mask, 0, 100000);
}

void SemanticOptions::validate() const {
  const char* s = kSection;
  requireThat(segmenter != SegmenterKind::kMaskDir || !mask_dir.empty(), s, "mask_dir",
              "segmenter is mask_dir but no mask_dir is given");
  requireThat(!dynamic_classes.empty(), s, "dynamic_classes", "needs at least one class id (15 = person)");
  for (int c : dynamic_classes) requireInRange(s, "dynamic_classes", c, 0, 255);
  requireInRange(s, "threads", threads, 1, 64);
  requireInRange(s, "realtime_max_rate_hz", realtime_max_rate_hz, 0.0, 1000.0);
}

void DenseOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "voxel_size", voxel_size, 0.001, 1.0);
  requireInRange(s, "min_depth", min_depth, 0.0, 100.0);
  requireInRange(s, "max_depth", max_depth, min_depth, 100.0);
  requireInRange(s, "pixel_stride", pixel_stride, 1, 64);
  requireInRange(s, "outlier_neighbors", outlier_neighbors, 0, 1000);
  requireInRange(s, "outlier_std_ratio", outlier_std_ratio, 0.01, 100.0);
  requireInRange(s, "octomap_resolution", octomap_resolution, 0.001, 10.0);
  requireInRange(s, "exclude_dilation_px", exclude_dilation_px, 0, 100);
  requireInRange(s, "depth_edge_ratio", depth_edge_ratio, 0.0, 10.0);
  requireInRange(s, "queue_capacity", queue_capacity, 1, 100000);
  requireInRange(s, "render_width", render_width, 16, 16384);
  requireInRange(s, "render_height", render_height, 16, 16384);
  requireInRange(s, "min_observations", min_observations, 1, 1000000);
  requireInRange(s, "carve_tolerance", carve_tolerance, 0.001, 10.0);
}

void RelocalisationOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "direct_index_level", direct_index_level, 0, 8);
  requireInRange(s, "max_candidates", max_candidates, 1, 1000);
  requireInRange(s, "group_score_ratio", group_score_ratio, 0.0, 1.0);
  requireInRange(s, "max_descriptor_distance", max_descriptor_distance, 0, 256);
  requireInRange(s, "match_ratio", match_ratio, 0.1, 1.0);
  requireInRange(s, "min_matches", min_matches, 4, 100000);
  requireInRange(s, "ransac_iterations", ransac_iterations, 1, 100000);
  requireInRange(s, "ransac_reprojection_px", ransac_reprojection_px, 0.1, 100.0);
  requireInRange(s, "ransac_confidence", ransac_confidence, 0.5, 0.999999);
  requireInRange(s, "min_pnp_inliers", min_pnp_inliers, 4, min_matches);
  requireInRange(s, "min_inliers", min_inliers, min_pnp_inliers, 100000);
  requireInRange(s, "search_radius_px", search_radius_px, 1.0, 200.0);
}

void LoopOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "min_keyframes_between_loops", min_keyframes_between_loops, 0, 100000);
  requireInRange(s, "min_consistent_keyframes", min_consistent_keyframes, 1, 100);
  requireInRange(s, "group_size", group_size, 0, 100);
  requireInRange(s, "group_score_ratio", group_score_ratio, 0.0, 1.0);
  requireInRange(s, "max_candidates", max_candidates, 1, 100);
  requireInRange(s, "confirm_keyframes", confirm_keyframes, 0, 100);
  requireInRange(s, "min_confirm_matches", min_confirm_matches, 3, 100000);
  requireInRange(s, "max_descriptor_distance", max_descriptor_distance, 1, 256);
  requireInRange(s, "match_ratio", match_ratio, 0.1, 1.0);
  requireInRange(s, "ransac_iterations", ransac_iterations, 1, 100000);
  requireInRange(s, "ransac_threshold_m", ransac_threshold_m, 1e-4, 1.0);
  requireInRange(s, "min_rigid_inliers", min_rigid_inliers, 3, 100000);
  requireInRange(s, "projection_radius_px", projection_radius_px, 1.0, 200.0);
  requireInRange(s, "min_loop_matches", min_loop_matches, min_rigid_inliers, 100000);
  requireInRange(s, "strong_covisibility_weight", strong_covisibility_weight, 1, 100000);
  requireInRange(s, "pose_graph_iterations", pose_graph_iterations, 1, 1000);
  requireInRange(s, "global_ba_iterations", global_ba_iterations, 1, 1000);
  requireInRange(s, "queue_capacity", queue_capacity, 1, 100000);
}

void AtlasOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "min_initial_features", min_initial_features, 10, 100000);
  requireInRange(s, "min_initial_cells", min_initial_cells, 1, 16);
  requireInRange(s, "new_map_after_lost_s", new_map_after_lost_s, 0.0, 3600.0);
  requireInRange(s, "young_map_keyframes", young_map_keyframes, 0, 100000);
  requireInRange(s, "merge_match_keyframes", merge_match_keyframes, 1, 100);
  requireInRange(s, "merge_min_consistent_keyframes", merge_min_consistent_keyframes, 1, 100);
}

void PlausibilityOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "window_s", window_s, 0.1, 60.0);
  requireInRange(s, "max_window_s", max_window_s, window_s, 600.0);
  requireInRange(s, "min_baseline_m", min_baseline_m, 0.001, 10.0);
  requireInRange(s, "max_pairs", max_pairs, 1, 1000);
  requireInRange(s, "min_pairs", min_pairs, 1, max_pairs);
  requireInRange(s, "max_spread", max_spread, 0.0, 1.0);
  requireInRange(s, "max_scale_error", max_scale_error, 1.01, 100.0);
  requireInRange(s, "warn_scale_error", warn_scale_error, 1.0, max_scale_error);
  requireInRange(s, "min_median_depth_m", min_median_depth_m, 0.0, 1000.0);
  requireInRange(s, "max_median_depth_m", max_median_depth_m, min_median_depth_m, 1000.0);
}

void BagOptions::validate() const {
  const char* s = kSection;
  for (const auto& [key, topic] : {std::pair<const char*, const std::string&>{"rgb_topic", rgb_topic},
                                   {"depth_topic", depth_topic}, {"camera_info_topic", camera_info_topic}}) {
    const bool name_ok = topic.size() > 1 && topic.front() == '/' &&
                         topic.find_first_of(" \t\r\n") == std::string::npos;
    requireThat(name_ok, s, key,
                "must be a full ROS topic name as a bag stores it, e.g. /camera/rgb/image_color, got '" + topic + "'");
  }
}

void SystemOptions::validate() const {
  camera.validate();
  orb.validate();
  tracking.validate();
  matching.validate();
  mapping.validate();
  dynamic.validate();
  semantic.validate();
  dense.validate();
  relocalisation.validate();
  loop.validate();
  atlas.validate();
  plausibility.validate();
  bag.validate();
}

}  // namespace desslam
