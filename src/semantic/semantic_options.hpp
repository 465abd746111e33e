// semantic.*: the segmenter and its thread (semantic/segmenter.hpp).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/option_fields.hpp"

namespace desslam {

// semantic.segmenter: where the masks come from.
enum class SegmenterKind { kDeepLab, kMaskDir, kNone };
constexpr std::array<EnumName<SegmenterKind>, 3> enumNames(SegmenterKind) {
  return {{{SegmenterKind::kDeepLab, "deeplab"}, {SegmenterKind::kMaskDir, "mask_dir"}, {SegmenterKind::kNone, "none"}}};
}

// semantic.backend: the inference library of the deeplab segmenter.
enum class SegmentationBackend { kOpenCv, kXnnpack };
constexpr std::array<EnumName<SegmentationBackend>, 2> enumNames(SegmentationBackend) {
  return {{{SegmentationBackend::kOpenCv, "opencv"}, {SegmentationBackend::kXnnpack, "xnnpack"}}};
}

struct SemanticOptions {
  SegmenterKind segmenter = SegmenterKind::kDeepLab;
  // Inference backend of the deeplab segmenter: xnnpack (XNNPACK: the same model file and
  // masks as OpenCV dnn, 4.7-6.4x faster on one thread, so real-time masks are fresher; needs
  // libxnnpack-dev at build time) | opencv (OpenCV dnn, the reference).
  SegmentationBackend backend = SegmentationBackend::kXnnpack;
  // Empty: looked for in $DESSLAM_SHARED_DIR/models, ../shared/models, <exe>/../../shared/models
  // (semantic::resolveModelPath) as deeplabv3_mnv2_voc_257.onnx.
  std::string model_path;
  // Checked before the model is loaded; empty skips the check (for a model of your own).
  std::string model_sha256 = "affb6c7119ea36f686f718f887f719db19091fb43014e16402148764c2a0d05d";
  std::string mask_dir;               // for segmenter = mask_dir: one PNG per RGB frame
  std::vector<int> dynamic_classes{15};  // PASCAL VOC ids (15 = person)
  // Threads for the network. backend = opencv: cv::setNumThreads() is process-wide, so the
  // application applies this; the semantic library never calls it. backend = xnnpack: the
  // segmenter's own thread pool (1 = on the semantic thread itself, no pool).
  int threads = 1;
  // Real-time mode (--realtime): the network starts at most this often (0 = as often as it can).
  // On 2 cores an unthrottled network takes a whole core and starves mapping; masks between are
  // carried forward along optical flow.
  double realtime_max_rate_hz = 10.0;
  // Real-time mode: a frame the network is segmenting (it starts on a frame as it arrives, while
  // tracking extracts features) waits up to this long for its own mask instead of taking the
  // previous one carried forward, as far as it then ends at most half a frame period behind the
  // sensor (judged from the previous frame's processing; the frames after it, which the resting
  // network leaves alone, catch up). 0: never waits.
  double realtime_mask_wait_ms = 20.0;
  // A keyframe made while the mask was carried forward (real time, emulated latency) gets its own
  // frame's mask before local mapping uses it (segmented for it when the stream skipped that
  // frame): the features in it leave the keyframe, and the points only it held leave the map.
  bool keyframe_exact_mask = true;
  // While tracking is lost (or no map has started), a frame waits for its own mask instead of
  // taking a carried one (real time: segmented at once, ahead of the stream). A grown, misplaced
  // mask leaves too few static features to relocalise or start a map, and a frame without a pose
  // loses nothing by being a few milliseconds later.
  bool own_mask_when_lost = true;

  static constexpr const char* kSection = "semantic";
  template <class V> void fields(V& v) {
    v("segmenter", segmenter); v("backend", backend); v("model_path", model_path); v("model_sha256", model_sha256);
    v("mask_dir", mask_dir); v("dynamic_classes", dynamic_classes); v("threads", threads);
    v("realtime_max_rate_hz", realtime_max_rate_hz); v("realtime_mask_wait_ms", realtime_mask_wait_ms); v("keyframe_exact_mask", keyframe_exact_mask);
    v("own_mask_when_lost", own_mask_when_lost);
  }
  void validate() const;
};

}  // namespace desslam
