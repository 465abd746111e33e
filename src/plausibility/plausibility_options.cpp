#include "plausibility/plausibility_options.hpp"

namespace desslam {

void PlausibilityOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "window_s", window_s, 0.1, 60.0);
  requireInRange(s, "max_window_s", max_window_s, window_s, 600.0);
  requireInRange(s, "min_baseline_m", min_baseline_m, 0.001, 10.0);
  requireInRange(s, "max_pairs", max_pairs, 1, 1000);
  requireInRange(s, "min_pairs", min_pairs, 1, max_pairs);
  requireInRange(s, "max_spread", max_spread, 0.0, 1.0);
  requireInRange(s, "max_direction_disagreement_deg", max_direction_disagreement_deg, 0.0, 180.0);
  requireInRange(s, "max_scale_error", max_scale_error, 1.01, 100.0);
  requireInRange(s, "warn_scale_error", warn_scale_error, 1.0, max_scale_error);
  requireInRange(s, "min_median_depth_m", min_median_depth_m, 0.0, 1000.0);
  requireInRange(s, "max_median_depth_m", max_median_depth_m, min_median_depth_m, 1000.0);
}

}  // namespace desslam
