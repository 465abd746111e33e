#include "system/debug_view.hpp"

#include <opencv2/imgproc.hpp>

namespace desslam::system {

cv::Mat drawDynamicDebugView(const cv::Mat& bgr, const cv::Mat& mask, const map::Frame& frame) {
  cv::Mat view = bgr.clone();
  if (!mask.empty()) {
    cv::Mat tint(view.size(), view.type(), cv::Scalar(255, 80, 0));  // blue tint over the mask
    cv::Mat blended;
    cv::addWeighted(view, 0.6, tint, 0.4, 0, blended);
    blended.copyTo(view, mask);
  }
  for (size_t i = 0; i < frame.features->size(); ++i) {
    cv::Scalar colour;
    switch (frame.status[i]) {
      case map::FeatureStatus::kStatic: colour = cv::Scalar(0, 220, 0); break;
      case map::FeatureStatus::kDynamicStage1: colour = cv::Scalar(0, 0, 255); break;
      case map::FeatureStatus::kDynamicStage2: colour = cv::Scalar(255, 0, 255); break;
      case map::FeatureStatus::kDynamicMask: colour = cv::Scalar(0, 140, 255); break;
      case map::FeatureStatus::kPendingStage1: colour = cv::Scalar(200, 200, 200); break;
    }
    const cv::Point2f p = frame.features->keypoints[i].pt;
    const bool matched = frame.matches[i].matched();
    cv::circle(view, p, matched ? 3 : 2, colour, matched ? -1 : 1, cv::LINE_AA);
  }
  cv::putText(view, "static", {10, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 220, 0), 1, cv::LINE_AA);
  cv::putText(view, "stage 1", {70, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
  cv::putText(view, "stage 2", {140, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 0, 255), 1, cv::LINE_AA);
  cv::putText(view, "mask", {210, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 140, 255), 1, cv::LINE_AA);
  return view;
}

}  // namespace desslam::system
