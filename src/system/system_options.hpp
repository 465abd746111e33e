// SystemOptions: every stage's options, one section each, as a run is configured (one YAML file,
// io/config.hpp). A target of its own (desslam_system_options) that links only the stages' option
// targets, so io can read a config without linking the stages, and a stage library includes only
// its own options: a stage that needs a few sections takes a struct of just those (e.g.
// tracking::TrackerOptions), never SystemOptions.
#pragma once

#include "bag/bag_options.hpp"
#include "core/camera_options.hpp"
#include "dense/dense_options.hpp"
#include "dynamic/dynamic_options.hpp"
#include "feature/orb_options.hpp"
#include "loop/loop_options.hpp"
#include "map/atlas_options.hpp"
#include "mapping/mapping_options.hpp"
#include "matching/matcher_options.hpp"
#include "plausibility/plausibility_options.hpp"
#include "semantic/semantic_options.hpp"
#include "tracking/tracking_options.hpp"

namespace desslam {

// Everything a run is configured with (one YAML file, one section per struct).
struct SystemOptions {
  CameraOptions camera;
  OrbOptions orb;
  TrackingOptions tracking;
  MatcherOptions matching;
  MappingOptions mapping;
  DynamicOptions dynamic;
  SemanticOptions semantic;
  DenseOptions dense;
  LoopOptions loop;
  RelocalisationOptions relocalisation;
  AtlasOptions atlas;
  PlausibilityOptions plausibility;
  BagOptions bag;

  template <class F> void sections(F&& f) {
    f(camera); f(orb); f(tracking); f(matching); f(mapping); f(dynamic); f(semantic); f(dense); f(loop); f(relocalisation); f(atlas);
    f(plausibility); f(bag);
  }
  void validate() const;
};

// The sections each stage class reads, picked from the whole run's options (the system and the
// tests build the tracker, local mapper and loop closer from SystemOptions).
tracking::TrackerOptions trackerOptions(const SystemOptions& options);
mapping::LocalMapperOptions localMapperOptions(const SystemOptions& options);
loop::LoopCloserOptions loopCloserOptions(const SystemOptions& options);

}  // namespace desslam
