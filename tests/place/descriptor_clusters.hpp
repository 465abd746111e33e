// Constructed binary descriptors for vocabulary tests: random centres and noisy copies of them.
#pragma once

#include <array>
#include <cstdint>
#include <random>
#include <vector>

#include <opencv2/core.hpp>

namespace desslam::place::test {

using Bits = std::array<uint8_t, 32>;

inline Bits randomBits(std::mt19937& rng) {
  Bits b;
  for (auto& byte : b) byte = uint8_t(rng() & 0xFF);
  return b;
}

// `center` with `flips` distinct random bits inverted.
inline Bits flipBits(const Bits& center, int flips, std::mt19937& rng) {
  Bits b = center;
  std::vector<int> bits(256);
  for (int i = 0; i < 256; ++i) bits[i] = i;
  std::shuffle(bits.begin(), bits.end(), rng);
  for (int i = 0; i < flips; ++i) b[bits[i] / 8] ^= uint8_t(1u << (bits[i] % 8));
  return b;
}

inline cv::Mat toMat(const std::vector<Bits>& rows) {
  cv::Mat m(int(rows.size()), 32, CV_8U);
  for (int r = 0; r < m.rows; ++r) std::copy(rows[r].begin(), rows[r].end(), m.ptr<uint8_t>(r));
  return m;
}

}  // namespace desslam::place::test
