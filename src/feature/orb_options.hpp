// orb.*: the ORB extractor (feature/orb_extractor.hpp).
#pragma once

#include "core/option_fields.hpp"

namespace desslam {

struct OrbOptions {
  int num_features = 1000;
  int num_levels = 8;
  double scale_factor = 1.2;
  int initial_fast_threshold = 20;  // tried first in each cell
  int min_fast_threshold = 7;       // fallback in cells where the first finds nothing
  int cell_size = 35;               // pixel size of the FAST detection grid cells

  static constexpr const char* kSection = "orb";
  template <class V> void fields(V& v) {
    v("num_features", num_features); v("num_levels", num_levels); v("scale_factor", scale_factor);
    v("initial_fast_threshold", initial_fast_threshold); v("min_fast_threshold", min_fast_threshold);
    v("cell_size", cell_size);
  }
  void validate() const;
};

}  // namespace desslam
