#include "map/atlas_options.hpp"

namespace desslam {

void AtlasOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "min_initial_features", min_initial_features, 10, 100000);
  requireInRange(s, "min_initial_cells", min_initial_cells, 1, 16);
  requireInRange(s, "new_map_after_lost_s", new_map_after_lost_s, 0.0, 3600.0);
  requireInRange(s, "start_free_space_check_s", start_free_space_check_s, 0.0, 10.0);
  requireInRange(s, "young_map_keyframes", young_map_keyframes, 0, 100000);
  requireInRange(s, "other_map_search_s", other_map_search_s, 0.0, 3600.0);
  requireInRange(s, "merge_min_consistent_keyframes", merge_min_consistent_keyframes, 1, 100);
  requireInRange(s, "merge_match_keyframes", merge_match_keyframes, 1, 100);
  requireInRange(s, "merge_evidence_min_inliers", merge_evidence_min_inliers, 0, 100000);
  requireInRange(s, "merge_evidence_ransac_inliers", merge_evidence_ransac_inliers, 3, 100000);
  requireInRange(s, "final_merge_min_confirm_matches", final_merge_min_confirm_matches, 0, 100000);
  requireInRange(s, "final_merge_agreement_m", final_merge_agreement_m, 0.0, 10.0);
  requireInRange(s, "final_merge_agreement_deg", final_merge_agreement_deg, 0.0, 180.0);
}

}  // namespace desslam
