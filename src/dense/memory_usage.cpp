#include "dense/memory_usage.hpp"

#include <fstream>
#include <string>

namespace desslam::dense {
namespace {

// "VmHWM:    123456 kB" -> bytes.
size_t statusField(const std::string& name) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(name + ":", 0) != 0) continue;
    try {
      return static_cast<size_t>(std::stoull(line.substr(name.size() + 1))) * 1024;
    } catch (const std::exception&) {
      return 0;
    }
  }
  return 0;
}

}  // namespace

size_t peakResidentBytes() { return statusField("VmHWM"); }
size_t residentBytes() { return statusField("VmRSS"); }

}  // namespace desslam::dense
