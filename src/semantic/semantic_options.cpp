#include "semantic/semantic_options.hpp"

namespace desslam {

void SemanticOptions::validate() const {
  const char* s = kSection;
  requireThat(segmenter != SegmenterKind::kMaskDir || !mask_dir.empty(), s, "mask_dir",
              "segmenter is mask_dir but no mask_dir is given");
  requireThat(!dynamic_classes.empty(), s, "dynamic_classes", "needs at least one class id (15 = person)");
  for (int c : dynamic_classes) requireInRange(s, "dynamic_classes", c, 0, 255);
  requireInRange(s, "threads", threads, 1, 64);
  requireInRange(s, "realtime_max_rate_hz", realtime_max_rate_hz, 0.0, 1000.0);
  requireInRange(s, "realtime_mask_wait_ms", realtime_mask_wait_ms, 0.0, 1000.0);
}

}  // namespace desslam
