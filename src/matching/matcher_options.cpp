#include "matching/matcher_options.hpp"

namespace desslam {

void MatcherOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "max_distance", max_distance, 0, 256);
  requireInRange(s, "strict_distance", strict_distance, 0, max_distance);
  requireInRange(s, "ratio", ratio, 0.1, 1.0);
}

}  // namespace desslam
