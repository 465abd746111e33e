#include "core/camera_options.hpp"

#include <cmath>
#include <sstream>

namespace desslam {

void CameraOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "width", width, 16, 16384);
  requireInRange(s, "height", height, 16, 16384);
  // The focal length against the image size: a horizontal field of view outside 20-170 degrees is
  // no RGB-D camera (typically 55-90); fy must give nearly square pixels.
  constexpr double kMinFovDeg = 20.0, kMaxFovDeg = 170.0;
  const double fx_lo = width / (2.0 * std::tan(kMaxFovDeg * M_PI / 360.0));
  const double fx_hi = width / (2.0 * std::tan(kMinFovDeg * M_PI / 360.0));
  if (!(std::isfinite(fx) && fx >= fx_lo && fx <= fx_hi)) {
    std::ostringstream msg;
    msg << "config key camera.fx = " << fx << " (pixels) is implausible for an image " << width
        << " pixels wide: ";
    if (std::isfinite(fx) && fx > 0)
      msg << "it gives a horizontal field of view of " << 2.0 * std::atan(width / (2.0 * fx)) * 180.0 / M_PI
          << " degrees; ";
    msg << "expected " << kMinFovDeg << "-" << kMaxFovDeg << " degrees, i.e. " << fx_lo << " <= fx <= " << fx_hi
        << " (TUM/Bonn: fx ~ 517-542 for 640 pixels)";
    throw ConfigError(msg.str());
  }
  if (!(std::isfinite(fy) && fy >= 0.5 * fx && fy <= 2.0 * fx)) {
    std::ostringstream msg;
    msg << "config key camera.fy = " << fy << " is implausible with camera.fx = " << fx
        << ": expected 0.5 * fx <= fy <= 2 * fx (pixels are nearly square; fy is usually within 1 % of fx)";
    throw ConfigError(msg.str());
  }
  requireInRange(s, "cx", cx, 0, width);
  requireInRange(s, "cy", cy, 0, height);
  for (double k : distortion) requireInRange(s, "distortion", k, -1000.0, 1000.0);
  requireThat(std::isfinite(depth_factor) && depth_factor > 0, s, "depth_factor",
              "must be positive: raw depth units per metre (5000 for TUM and Bonn, 1000 for mm)");
  requireInRange(s, "depth_factor", depth_factor, 1.0, 1e6);
  requireInRange(s, "fps", fps, 0.1, 1000);
  requireInRange(s, "depth_baseline", depth_baseline, 0.001, 10.0);
}

}  // namespace desslam
