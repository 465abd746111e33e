#include "dynamic/mask_propagation.hpp"

#include <string>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace desslam::dynamic {

MaskPropagator::MaskPropagator(int downscale, size_t history)
    : downscale_(downscale), history_(history), flow_(cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_ULTRAFAST)) {
  if (downscale_ < 1 || history_ < 1) throw InputError("MaskPropagator: downscale and history must be at least 1");
}

void MaskPropagator::addFrame(uint64_t frame_id, const cv::Mat& gray) {
  if (gray.empty() || gray.type() != CV_8UC1) throw InputError("MaskPropagator::addFrame: expected a CV_8UC1 image");
  const cv::Size small_size(std::max(1, gray.cols / downscale_), std::max(1, gray.rows / downscale_));
  cv::Mat small;
  cv::resize(gray, small, small_size, 0, 0, cv::INTER_AREA);
  const bool continues = has_frame_ && frame_id == newest_id_ + 1 && gray.size() == full_size_;
  if (!continues) {
    steps_.clear();
    cached_ = false;
  } else {
    cv::Mat flow;  // current pixel -> displacement to where it was in the previous frame
    flow_->calc(small, previous_small_, flow);
    cv::Mat map(flow.size(), CV_32FC2);
    for (int y = 0; y < flow.rows; ++y) {
      const cv::Vec2f* f = flow.ptr<cv::Vec2f>(y);
      cv::Vec2f* m = map.ptr<cv::Vec2f>(y);
      for (int x = 0; x < flow.cols; ++x) m[x] = cv::Vec2f(x + f[x][0], y + f[x][1]);
    }
    steps_.push_back({frame_id, map});
    while (steps_.size() > history_) steps_.pop_front();
  }
  previous_small_ = small;
  newest_id_ = frame_id;
  full_size_ = gray.size();
  has_frame_ = true;
}

cv::Mat MaskPropagator::carry(uint64_t source_id, const cv::Mat& source_mask) {
  if (source_mask.type() != CV_8UC1 || source_mask.size() != full_size_)
    throw InputError("MaskPropagator::carry: expected a CV_8UC1 mask of the frames' size " +
                     std::to_string(full_size_.width) + "x" + std::to_string(full_size_.height));
  if (!has_frame_ || source_id > newest_id_) return {};
  if (source_id == newest_id_) return source_mask > 0;
  if (steps_.empty() || steps_.front().frame_id > source_id + 1) return {};  // older than the flow kept

  uint64_t at = source_id;
  cv::Mat mask;
  if (cached_ && cached_source_ == source_id && cached_upto_ >= source_id && cached_upto_ <= newest_id_) {
    at = cached_upto_;
    mask = cached_mask_;
  } else {
    cv::Mat as_float;
    source_mask.convertTo(as_float, CV_32F, 1.0 / 255.0);
    cv::threshold(as_float, as_float, 0.0, 1.0, cv::THRESH_BINARY);  // any nonzero value is dynamic
    cv::resize(as_float, mask, steps_.front().map.size(), 0, 0, cv::INTER_AREA);
  }
  for (const FlowStep& step : steps_) {
    if (step.frame_id <= at) continue;
    cv::Mat moved;
    cv::remap(mask, moved, step.map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
    mask = moved;
  }
  cached_ = true;
  cached_source_ = source_id;
  cached_upto_ = newest_id_;
  cached_mask_ = mask;
  cv::Mat full;
  cv::resize(mask, full, full_size_, 0, 0, cv::INTER_LINEAR);
  return full > 0.5f;
}

}  // namespace desslam::dynamic
