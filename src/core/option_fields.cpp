#include "core/option_fields.hpp"

#include <cmath>
#include <sstream>

namespace desslam {

void requireInRange(const char* section, const char* key, double value, double lo, double hi) {
  if (std::isfinite(value) && value >= lo && value <= hi) return;  // NaN fails both comparisons too
  std::ostringstream msg;
  msg << "config key " << section << "." << key << " = " << value << " is out of range: expected "
      << lo << " <= value <= " << hi;
  throw ConfigError(msg.str());
}

void requireThat(bool ok, const char* section, const char* key, const std::string& message) {
  if (!ok) throw ConfigError(std::string("config key ") + section + "." + key + ": " + message);
}

}  // namespace desslam
