// What every stage's options struct is made of. The structs live in their stage's library
// (dense/dense_options.hpp, tracking/tracking_options.hpp, ...), each with its defaults, a
// validate() that throws ConfigError naming the bad key ("section.key"), and its section name
// kSection; system/system_options.hpp gathers them into SystemOptions, which io/config.hpp reads
// from YAML. Each struct lives apart so that changing one stage's options recompiles only its users.
//
// Each struct lists its keys once in fields(v), v(key, member): the YAML loader, the report
// writer and unknown-key detection all use that list, so a new option is added in one place.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/error.hpp"

namespace desslam {

// Throws ConfigError "<section>.<key> = <value>: <requirement>" unless lo <= value <= hi.
void requireInRange(const char* section, const char* key, double value, double lo, double hi);
// Throws ConfigError "<section>.<key>: <message>" unless ok.
void requireThat(bool ok, const char* section, const char* key, const std::string& message);

// Options whose value is one of a few names (dynamic.mode: off | semantic | geometric | full) are
// enum classes. Each lists its names once, in a function enumNames(E) beside the enum (found by
// argument-dependent lookup): the YAML reader parses them (an unknown name is an error listing the
// allowed ones), report.json writes them, and nothing else compares strings.
template <class E> struct EnumName {
  E value;
  const char* name;
};
template <class E>
concept NamedEnum = std::is_enum_v<E> && requires { enumNames(E{}); };

template <NamedEnum E> const char* nameOf(E value) {
  for (const auto& entry : enumNames(E{}))
    if (entry.value == value) return entry.name;
  return "?";  // not reachable for a value the enum lists
}
template <NamedEnum E> std::optional<E> enumFromName(std::string_view name) {
  for (const auto& entry : enumNames(E{}))
    if (name == entry.name) return entry.value;
  return std::nullopt;
}
template <NamedEnum E> std::vector<std::string> enumNameList() {
  std::vector<std::string> names;
  for (const auto& entry : enumNames(E{})) names.emplace_back(entry.name);
  return names;
}

}  // namespace desslam
