#include "tracking/tracking_options.hpp"

#include <string>

namespace desslam {

void TrackingOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "min_depth", min_depth, 0.0, 10.0);
  requireInRange(s, "max_depth", max_depth, min_depth, 100.0);
  requireInRange(s, "close_depth", close_depth, min_depth, max_depth);
  requireInRange(s, "min_inliers", min_inliers, 4, 1000);
  requireInRange(s, "max_speed_m_s", max_speed_m_s, 0.01, 1000.0);
  requireInRange(s, "max_acceleration_m_s2", max_acceleration_m_s2, 0.0, 1000.0);
  requireThat(bridge_overruled_inlier_ratio == 0.0 ||
                  (bridge_overruled_inlier_ratio >= 1.0 && bridge_overruled_inlier_ratio <= 100.0),
              s, "bridge_overruled_inlier_ratio",
              "is " + std::to_string(bridge_overruled_inlier_ratio) +
                  "; expected 0 (off) or 1-100 (a pose found again must be at least as well supported as the bridge)");
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
  requireInRange(s, "vo_check_min_map_inliers", vo_check_min_map_inliers, 0, 10000);
  requireInRange(s, "backfill_max_s", backfill_max_s, 0.0, 60.0);
  requireInRange(s, "predict_back_s", predict_back_s, 0.0, 60.0);
  requireInRange(s, "interpolate_predictions_within_s", interpolate_predictions_within_s, 0.0, 60.0);
  requireInRange(s, "hold_pose_s", hold_pose_s, 0.0, 60.0);
  requireThat(odometry_min_inliers == 0 || (odometry_min_inliers >= 6 && odometry_min_inliers <= 10000), s,
              "odometry_min_inliers",
              "is " + std::to_string(odometry_min_inliers) + "; expected 0 (off) or 6-10000 (PnP needs 6 points)");
  requireInRange(s, "odometry_keyframe_after_s", odometry_keyframe_after_s, 0.0, 60.0);
  requireInRange(s, "odometry_keyframe_max_masked_share", odometry_keyframe_max_masked_share, 0.0, 1.0);
  requireInRange(s, "odometry_keyframe_min_clear_inliers", odometry_keyframe_min_clear_inliers, 0, 10000);
  requireInRange(s, "depth_odometry_max_s", depth_odometry_max_s, 0.0, 60.0);
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

}  // namespace desslam
