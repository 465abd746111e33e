// Binary descriptor primitives: ORB descriptors are 256 bits (32 bytes), compared by Hamming
// distance (number of differing bits, 0..256).
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

namespace desslam::feature {

inline constexpr int kDescriptorBytes = 32;
inline constexpr int kMaxDescriptorDistance = 8 * kDescriptorBytes;

// Hamming distance of two 32-byte ORB descriptors (four 64-bit popcounts; no alignment needed).
int descriptorDistance(const uint8_t* a, const uint8_t* b);

// Same for two 1x32 CV_8U rows (e.g. descriptors.row(i)); the caller guarantees the shape.
inline int descriptorDistance(const cv::Mat& a, const cv::Mat& b) {
  CV_DbgAssert(a.type() == CV_8UC1 && b.type() == CV_8UC1 && a.total() == kDescriptorBytes &&
               b.total() == kDescriptorBytes && a.isContinuous() && b.isContinuous());
  return descriptorDistance(a.ptr<uint8_t>(), b.ptr<uint8_t>());
}

}  // namespace desslam::feature
