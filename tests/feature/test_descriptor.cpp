#include <array>
#include <cstdint>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "feature/descriptor.hpp"

namespace desslam::feature {
namespace {

TEST(DescriptorDistance, KnownBitPatterns) {
  std::array<uint8_t, 32> zeros{}, ones{}, alternating{}, inverted{};
  ones.fill(0xFF);
  alternating.fill(0xAA);  // 10101010
  inverted.fill(0x55);     // 01010101
  EXPECT_EQ(descriptorDistance(zeros.data(), zeros.data()), 0);
  EXPECT_EQ(descriptorDistance(zeros.data(), ones.data()), 256);
  EXPECT_EQ(descriptorDistance(ones.data(), zeros.data()), 256);
  EXPECT_EQ(descriptorDistance(zeros.data(), alternating.data()), 128);
  EXPECT_EQ(descriptorDistance(alternating.data(), inverted.data()), 256);
  EXPECT_EQ(descriptorDistance(ones.data(), alternating.data()), 128);
}

TEST(DescriptorDistance, EverySingleBitCountsOnce) {
  for (int bit = 0; bit < 256; ++bit) {
    std::array<uint8_t, 32> a{}, b{};
    b[bit / 8] = static_cast<uint8_t>(1u << (bit % 8));
    ASSERT_EQ(descriptorDistance(a.data(), b.data()), 1) << "bit " << bit;
  }
  // Bits in the first and last byte of every 64-bit word (word boundaries are where a wrong
  // stride or a missed tail would show).
  std::array<uint8_t, 32> a{}, b{};
  for (int word = 0; word < 4; ++word) {
    b[word * 8] = 0x01;
    b[word * 8 + 7] = 0x80;
  }
  EXPECT_EQ(descriptorDistance(a.data(), b.data()), 8);
}

TEST(DescriptorDistance, AgreesWithOpenCvHammingOnRandomRowsAndUnalignedData) {
  cv::RNG rng(7);
  // 33 columns, used from column 1: rows start at odd addresses.
  cv::Mat wide(200, 33, CV_8U);
  rng.fill(wide, cv::RNG::UNIFORM, 0, 256);
  const cv::Mat rows = wide.colRange(1, 33);
  for (int i = 0; i + 1 < rows.rows; ++i) {
    const cv::Mat a = rows.row(i), b = rows.row(i + 1);
    const int expected = static_cast<int>(cv::norm(a, b, cv::NORM_HAMMING));
    ASSERT_EQ(descriptorDistance(a.ptr<uint8_t>(), b.ptr<uint8_t>()), expected) << "row " << i;
    ASSERT_EQ(descriptorDistance(a, b), expected) << "row " << i;
  }
}

}  // namespace
}  // namespace desslam::feature
