#include "feature/orb_options.hpp"

namespace desslam {

void OrbOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "num_features", num_features, 50, 20000);
  requireInRange(s, "num_levels", num_levels, 1, 16);
  requireInRange(s, "scale_factor", scale_factor, 1.01, 2.0);
  requireInRange(s, "initial_fast_threshold", initial_fast_threshold, 1, 255);
  requireInRange(s, "min_fast_threshold", min_fast_threshold, 1, initial_fast_threshold);
  requireInRange(s, "cell_size", cell_size, 10, 200);
}

}  // namespace desslam
