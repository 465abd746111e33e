#include "plausibility/sequence_check.hpp"

#include <algorithm>
#include <optional>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace desslam::plausibility {

CheckResult checkSequence(const io::RgbdSequence& sequence, const CameraOptions& camera,
                          const PlausibilityOptions& options, size_t frame_count) {
  const size_t count = frame_count == 0 ? sequence.size() : std::min(frame_count, sequence.size());
  if (count == 0) return {};
  const std::optional<Trajectory>& gt = sequence.groundTruth();
  std::vector<Timestamp> stamps;
  std::vector<std::optional<SE3>> reference;
  for (size_t i = 0; i < count; ++i) {
    const Timestamp rgb_timestamp = sequence.rgbTimestamp(i);
    if (rgb_timestamp - sequence.rgbTimestamp(0) > options.max_window_s) break;
    stamps.push_back(rgb_timestamp);
    if (gt) reference.push_back(interpolatePose(*gt, rgb_timestamp));
  }
  std::vector<CheckFrame> frames;
  for (size_t i : selectFrames(stamps, reference, options)) {
    try {
      const io::RgbdImage image = sequence.load(i, camera);
      CheckFrame frame;
      frame.timestamp = image.timestamp;
      cv::cvtColor(image.bgr, frame.gray, cv::COLOR_BGR2GRAY);
      frame.depth = image.depth;
      if (gt) {
        frame.T_w_c_rgb = reference[i];
        frame.T_w_c_depth = interpolatePose(*gt, sequence.depthTimestamp(i));
      }
      frames.push_back(std::move(frame));
    } catch (const InputError&) {
      // Left out here; the run's frame loop reports it with the outputs computed so far.
    }
  }
  if (frames.empty()) return {};
  return checkDepthScale(frames, camera, options);
}

}  // namespace desslam::plausibility
