#include "mapping/mapping_options.hpp"

namespace desslam {

void MappingOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "covisible_for_triangulation", covisible_for_triangulation, 1, 100);
  requireInRange(s, "local_ba_iterations", local_ba_iterations, 1, 1000);
  requireInRange(s, "redundant_keyframe_ratio", redundant_keyframe_ratio, 0.0, 1.0);
  requireInRange(s, "global_ba_iterations", global_ba_iterations, 1, 1000);
}

}  // namespace desslam
