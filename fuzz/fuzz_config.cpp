// libFuzzer target: the YAML config loader (duplicate keys, unknown keys, types, validation) and,
// for the input's first line, the --set override parser.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.hpp"
#include "io/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    desslam::SystemOptions options = desslam::io::loadConfigFromString(text, "fuzz.yaml");
    (void)desslam::io::optionsToJson(options).dump();
  } catch (const desslam::ConfigError&) {
  }
  desslam::SystemOptions options;
  try {
    desslam::io::applyOverride(options, text.substr(0, text.find('\n')));
  } catch (const desslam::ConfigError&) {
  }
  return 0;
}
