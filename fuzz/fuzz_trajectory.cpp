// libFuzzer target: the TUM trajectory reader (groundtruth.txt, CameraTrajectory.txt).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/trajectory_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::vector<std::string> warnings;
  try {
    const desslam::Trajectory trajectory = desslam::io::parseTumTrajectory(in, "fuzz/trajectory.txt", &warnings);
    // What the reader accepts is finite (eval relies on it).
    for (const auto& p : trajectory)
      if (!std::isfinite(p.timestamp) || !p.T_w_c.translation().allFinite() ||
          !p.T_w_c.quaternion().coeffs().allFinite())
        __builtin_trap();
  } catch (const desslam::InputError&) {
  }
  return 0;
}
