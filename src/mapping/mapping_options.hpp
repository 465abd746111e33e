// mapping.*: local mapping (mapping/local_mapper.hpp).
#pragma once

#include "core/option_fields.hpp"
#include "matching/matcher_options.hpp"
#include "tracking/tracking_options.hpp"

namespace desslam {

struct MappingOptions {
  int covisible_for_triangulation = 10;  // neighbours searched for new points
  int local_ba_iterations = 10;
  bool local_ba = true;
  double redundant_keyframe_ratio = 0.9;  // culled when this share of its points is seen by >= 3 others
  // After the last frame: one bundle adjustment over every keyframe and point, so the saved
  // trajectory does not depend on how far local mapping kept up during the run.
  bool final_global_ba = true;
  int global_ba_iterations = 20;

  static constexpr const char* kSection = "mapping";
  template <class V> void fields(V& v) {
    v("covisible_for_triangulation", covisible_for_triangulation);
    v("local_ba_iterations", local_ba_iterations); v("local_ba", local_ba);
    v("redundant_keyframe_ratio", redundant_keyframe_ratio);
    v("final_global_ba", final_global_ba); v("global_ba_iterations", global_ba_iterations);
  }
  void validate() const;
};

namespace mapping {
// The sections of the run's options local mapping reads (system/system_options.hpp:
// localMapperOptions); only these, so that another stage's options do not recompile it.
struct LocalMapperOptions {
  MappingOptions mapping;
  MatcherOptions matching;
  TrackingOptions tracking;  // close_depth: "close" points as the tracker counts them
};
}  // namespace mapping

}  // namespace desslam
