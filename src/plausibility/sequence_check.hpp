// The depth-scale check (plausibility/depth_scale.hpp) on a sequence (TUM folder or ROS bag):
// picks a few of its first frames, loads them, attaches the ground-truth poses when there are any.
#pragma once

#include <cstddef>

#include "core/camera_options.hpp"
#include "io/rgbd_sequence.hpp"
#include "plausibility/depth_scale.hpp"
#include "plausibility/plausibility_options.hpp"

namespace desslam::plausibility {

// Looks at the first frames among the first `frame_count` of `sequence` (all when 0), read with
// `camera`. A frame that cannot be loaded is left out (the run meets it and reports it). Returns
// an empty result (no findings) when no frame could be loaded.
CheckResult checkSequence(const io::RgbdSequence& sequence, const CameraOptions& camera,
                          const PlausibilityOptions& options, size_t frame_count = 0);

}  // namespace desslam::plausibility
