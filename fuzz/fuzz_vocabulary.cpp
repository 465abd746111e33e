// libFuzzer target: the vocabulary file loader. The input is the file without its trailing
// checksum, which is computed here (the loader's own 64-bit FNV-style hash) so that the fuzzer
// reaches the header and tree checks instead of stopping at the checksum; a loaded vocabulary
// then transforms a few descriptors taken from the input.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "place/vocabulary.hpp"

namespace {
uint64_t checksum(const uint8_t* data, size_t size) {  // as place/vocabulary.cpp computes it
  uint64_t hash = 1469598103934665603ull;
  for (size_t i = 0; i < size; ++i) {
    hash ^= data[i];
    hash *= 1099511628211ull;
  }
  return hash;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  const uint64_t sum = checksum(data, size);
  for (int i = 0; i < 8; ++i) bytes.push_back(static_cast<uint8_t>(sum >> (8 * i)));
  try {
    const desslam::place::Vocabulary vocabulary = desslam::place::Vocabulary::fromBytes(bytes, "fuzz.bin");
    cv::Mat descriptors(4, 32, CV_8U);
    for (int i = 0; i < 4 * 32; ++i) descriptors.data[i] = size > 0 ? data[static_cast<size_t>(i) % size] : 0;
    desslam::place::BowVector bow;
    vocabulary.transform(descriptors, bow);
  } catch (const desslam::InputError&) {
  }
  return 0;
}
