// The map check on a finished run's files (what `desslam mapcheck` does): the exported map
// (dense_map.ply), its sidecar of first-seen times (dense_map_sources.bin), the keyframe poses
// (KeyFrameTrajectory.txt) and the sequence's depth images of those keyframes.
#pragma once

#include <filesystem>

#include "core/camera_options.hpp"
#include "dense/map_check.hpp"

namespace desslam::dense {

struct RunMapCheckResult {
  size_t map_points = 0;
  size_t keyframes = 0;
  MapCheckResult check;
};

// Throws InputError naming the file and the fix when a run file is missing, the sidecar does
// not match the map, a keyframe has no RGB-D pair (or depth image) in sequence_dir, or a depth
// image has the wrong size for `camera`.
RunMapCheckResult checkRunMap(const std::filesystem::path& out_dir, const std::filesystem::path& sequence_dir,
                              const CameraOptions& camera, const MapCheckOptions& options = {});

}  // namespace desslam::dense
