#include "dynamic/dynamic_options.hpp"

namespace desslam {

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

}  // namespace desslam
