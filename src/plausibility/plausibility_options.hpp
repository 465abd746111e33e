// plausibility.*: the input checks before a run.
#pragma once

#include "core/option_fields.hpp"

namespace desslam {

// Plausibility of the depth scale over the first frames of a run (plausibility/depth_scale.hpp):
// the camera's motion measured through the depth images (PnP on depth-backed ORB features) is
// compared with the same motion in metres from the sequence's ground truth; a depth factor that
// makes them disagree by max_scale_error or more is an error (`run --force`: a warning).
struct PlausibilityOptions {
  bool enabled = true;
  double window_s = 1.0;       // the first second of frames is looked at ...
  double max_window_s = 3.0;   // ... or longer (up to this) while the camera has moved too little
  // A frame pair counts when the camera moved this far (ground truth). The reference's own error
  // (a motion-capture body offset from the optical centre, clock offsets: millimetres to a
  // centimetre) is divided by the baseline: Bonn crowd measured 1.23x at 3-8 cm, 0.96x at 11-20 cm.
  double min_baseline_m = 0.10;
  int max_pairs = 8;           // frame pairs measured (spread over the window)
  int min_pairs = 3;           // fewer measured pairs: the scale is not judged
  // Per-pair ratios may spread (median absolute deviation / median) up to this; more: not judged.
  double max_spread = 0.25;
  // A pair counts only when its PnP and essential-matrix directions of motion agree within this
  // (degrees); a pair without an essential matrix counts. The depth factor scales the PnP motion
  // but cannot turn it, so this leaves out pairs whose matches hold two motions (walkers filling
  // the view: the Bonn crowd clip had its 3 pairs 26-54 degrees apart and read 0.74x with the
  // right factor; fr1_xyz's and fr1_desk's pairs lie at 2-7.5 degrees, Bonn crowd's first seconds
  // at 6.6-15.3 but for one at 31.5).
  double max_direction_disagreement_deg = 20.0;
  double max_scale_error = 1.5;   // measured ratio above this or below 1/this: an error
  double warn_scale_error = 1.15; // ... above this (below 1/this): a warning
  // Depth range of an indoor RGB-D camera: the median valid reading of the first frames outside
  // it is an error whether or not there is ground truth.
  double min_median_depth_m = 0.1;
  double max_median_depth_m = 20.0;

  static constexpr const char* kSection = "plausibility";
  template <class V> void fields(V& v) {
    v("enabled", enabled); v("window_s", window_s); v("max_window_s", max_window_s);
    v("min_baseline_m", min_baseline_m); v("max_pairs", max_pairs); v("min_pairs", min_pairs);
    v("max_spread", max_spread); v("max_direction_disagreement_deg", max_direction_disagreement_deg);
    v("max_scale_error", max_scale_error); v("warn_scale_error", warn_scale_error);
    v("min_median_depth_m", min_median_depth_m); v("max_median_depth_m", max_median_depth_m);
  }
  void validate() const;
};

}  // namespace desslam
