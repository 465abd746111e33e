// libFuzzer target: the "timestamp filename" list reader (rgb.txt, depth.txt) with tie warnings.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/tum_dataset.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::vector<std::string> warnings;
  try {
    const auto entries = desslam::io::parseTimestampList(in, "fuzz/rgb.txt", &warnings);
    for (const auto& e : entries)
      if (e.line <= 0 || e.file.empty()) __builtin_trap();  // every entry names its line and file
  } catch (const desslam::InputError&) {
  }
  return 0;
}
