// Error types: every message names the file or key at fault and says how to fix it.
#pragma once

#include <stdexcept>
#include <string>

namespace desslam {

// A bad configuration value or key (message names the key, e.g. "orb.num_levels").
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Bad input data: missing folder/file, unreadable image, wrong depth format, empty list.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace desslam
