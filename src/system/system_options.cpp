#include "system/system_options.hpp"

namespace desslam {

void SystemOptions::validate() const {
  camera.validate();
  orb.validate();
  tracking.validate();
  matching.validate();
  mapping.validate();
  dynamic.validate();
  semantic.validate();
  dense.validate();
  relocalisation.validate();
  loop.validate();
  atlas.validate();
  plausibility.validate();
  bag.validate();
}

tracking::TrackerOptions trackerOptions(const SystemOptions& options) {
  return {.tracking = options.tracking, .matching = options.matching, .dynamic = options.dynamic,
          .relocalisation = options.relocalisation, .atlas = options.atlas};
}

mapping::LocalMapperOptions localMapperOptions(const SystemOptions& options) {
  return {.mapping = options.mapping, .matching = options.matching, .tracking = options.tracking};
}

loop::LoopCloserOptions loopCloserOptions(const SystemOptions& options) {
  return {.loop = options.loop, .matching = options.matching, .atlas = options.atlas};
}

}  // namespace desslam
