// matching.*: ORB matching (matching/matcher.hpp), shared by tracking, local mapping and loop closing.
#pragma once

#include "core/option_fields.hpp"

namespace desslam {

// ORB matching by projection and descriptor (matching/matcher.hpp) in tracking, local mapping and
// loop closing. Depth agreement is judged in pixels of virtual disparity, with the camera's bf().
struct MatcherOptions {
  int max_distance = 100;     // Hamming distance accepted for a match
  int strict_distance = 50;   // for matches without geometric guidance
  double ratio = 0.8;         // best / second-best (different features) must be below this
  bool check_orientation = true;

  static constexpr const char* kSection = "matching";
  template <class V> void fields(V& v) {
    v("max_distance", max_distance); v("strict_distance", strict_distance); v("ratio", ratio);
    v("check_orientation", check_orientation);
  }
  void validate() const;
};

}  // namespace desslam
