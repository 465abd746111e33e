// Internal to sim: seeded random surface textures that suit ORB (FAST corners + rBRIEF).
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

namespace desslam::sim {

// A CV_8UC3 texture for a surface of width_m x height_m metres at px_per_m texels per metre:
// random shapes (polygons, ellipses, bars) of log-uniform size from ~1 cm to ~45 cm, drawn
// largest first so the small ones stay visible, alternating dark and bright so edges are
// strong in grey. The same seed gives the same texture; no two seeds give similar patterns.
cv::Mat makeSurfaceTexture(double width_m, double height_m, double px_per_m, std::uint64_t seed);

}  // namespace desslam::sim
