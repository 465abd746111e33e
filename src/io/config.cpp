#include "io/config.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>
#include <type_traits>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "core/error.hpp"

namespace desslam::io {
namespace {

// Where a value came from, for error messages: "config/tum_fr1.yaml" or "--set 'a.b=c'".
struct Origin {
  std::string source;
  bool has_lines = true;  // false for --set: a one-line value has no useful line number
  std::string at(const YAML::Node& node) const {
    const YAML::Mark mark = node.Mark();
    if (!has_lines || mark.is_null()) return source;
    return source + ":" + std::to_string(mark.line + 1);
  }
};

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string closest(const std::string& name, const std::vector<std::string>& known) {
  return *std::min_element(known.begin(), known.end(), [&](const std::string& a, const std::string& b) {
    return editDistance(name, a) < editDistance(name, b);
  });
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

std::string shown(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  if (node.IsMap()) return "a map";
  return "nothing";
}

std::string lineOf(const YAML::Mark& mark) { return mark.is_null() ? "?" : std::to_string(mark.line + 1); }

// A map key as a name; keys that are lists, maps or nothing are an error (options have plain names).
std::string keyName(const YAML::Node& key, const Origin& origin, const std::string& where) {
  if (!key.IsScalar())
    throw ConfigError(origin.at(key) + ": a key in " + where + " is " + shown(key) +
                      ", expected a plain name ('key: value')");
  return key.Scalar();
}

// yaml-cpp keeps duplicate keys in the node but lookups see only one of them: a config that sets
// a key twice would silently use one value. Every map in the document is checked, and the error
// names both lines.
void rejectDuplicateKeys(const YAML::Node& node, const std::string& path, const Origin& origin, int depth = 0) {
  if (depth > 64) throw ConfigError(origin.at(node) + ": the config is nested too deeply (more than 64 levels)");
  if (node.IsMap()) {
    std::vector<std::pair<std::string, YAML::Mark>> seen;
    for (const auto& item : node) {
      const std::string key = keyName(item.first, origin, path.empty() ? "the top level" : path);
      const std::string full = path.empty() ? key : path + "." + key;
      const auto earlier = std::find_if(seen.begin(), seen.end(), [&](const auto& s) { return s.first == key; });
      if (earlier != seen.end()) {
        const bool section = path.empty();
        throw ConfigError(origin.source + ":" + lineOf(item.first.Mark()) + ": duplicate config " +
                          (section ? "section '" + full + "'" : "key " + full) + ": already at line " +
                          lineOf(earlier->second) + " (line " + lineOf(earlier->second) + " and line " +
                          lineOf(item.first.Mark()) + "); YAML would keep only one of them: " +
                          (section ? "merge the two sections" : "remove one"));
      }
      seen.emplace_back(key, item.first.Mark());
      rejectDuplicateKeys(item.second, full, origin, depth + 1);
    }
  } else if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i)
      rejectDuplicateKeys(node[i], path + "[" + std::to_string(i) + "]", origin, depth + 1);
  }
}

[[noreturn]] void wrongType(const Origin& origin, const YAML::Node& node, const std::string& key,
                            const std::string& expected) {
  throw ConfigError(origin.at(node) + ": config key " + key + ": expected " + expected + ", got " + shown(node));
}

// One reader per member type that fields() lists; `key` is "section.key".
void readValue(const YAML::Node& node, double& out, const std::string& key, const Origin& origin) {
  double v = 0;
  if (!node.IsScalar() || !YAML::convert<double>::decode(node, v) || !std::isfinite(v))
    wrongType(origin, node, key, "a number");
  out = v;
}

void readValue(const YAML::Node& node, int& out, const std::string& key, const Origin& origin) {
  int v = 0;
  if (!node.IsScalar() || !YAML::convert<int>::decode(node, v)) wrongType(origin, node, key, "an integer");
  out = v;
}

void readValue(const YAML::Node& node, bool& out, const std::string& key, const Origin& origin) {
  bool v = false;
  if (!node.IsScalar() || !YAML::convert<bool>::decode(node, v)) wrongType(origin, node, key, "true or false");
  out = v;
}

void readValue(const YAML::Node& node, std::string& out, const std::string& key, const Origin& origin) {
  if (node.IsNull()) {  // "model_path:" means empty, i.e. the default location
    out.clear();
    return;
  }
  if (!node.IsScalar()) wrongType(origin, node, key, "a string");
  out = node.Scalar();
}

// An enum option by name; an unknown name is an error listing the allowed ones and the closest.
template <NamedEnum E> void readValue(const YAML::Node& node, E& out, const std::string& key, const Origin& origin) {
  const std::vector<std::string> names = enumNameList<E>();
  if (!node.IsScalar()) wrongType(origin, node, key, "one of " + joined(names));
  const std::optional<E> value = enumFromName<E>(node.Scalar());
  if (!value)
    throw ConfigError(origin.at(node) + ": config key " + key + " = '" + node.Scalar() + "' is not one of " +
                      joined(names) + ": did you mean '" + closest(node.Scalar(), names) + "'?");
  out = *value;
}

template <std::size_t N>
void readValue(const YAML::Node& node, std::array<double, N>& out, const std::string& key, const Origin& origin) {
  const std::string expected = "a list of " + std::to_string(N) + " numbers";
  if (!node.IsSequence() || node.size() != N) wrongType(origin, node, key, expected);
  std::array<double, N> v{};
  for (std::size_t i = 0; i < N; ++i)
    if (!node[i].IsScalar() || !YAML::convert<double>::decode(node[i], v[i]) || !std::isfinite(v[i]))
      wrongType(origin, node[i], key + "[" + std::to_string(i) + "]", "a number");
  out = v;
}

void readValue(const YAML::Node& node, std::vector<int>& out, const std::string& key, const Origin& origin) {
  if (!node.IsSequence()) wrongType(origin, node, key, "a list of integers");
  std::vector<int> v(node.size());
  for (std::size_t i = 0; i < node.size(); ++i)
    if (!node[i].IsScalar() || !YAML::convert<int>::decode(node[i], v[i]))
      wrongType(origin, node[i], key + "[" + std::to_string(i) + "]", "an integer");
  out = std::move(v);
}

// fields() visitor collecting key names.
struct KeyLister {
  std::vector<std::string> keys;
  template <class T> void operator()(const char* key, T&) { keys.emplace_back(key); }
};

template <class Section> std::vector<std::string> keysOf(Section& section) {
  KeyLister lister;
  section.fields(lister);
  return lister.keys;
}

// fields() visitor reading the keys present in a YAML map.
struct SectionReader {
  const YAML::Node& map;
  std::string section;
  const Origin& origin;
  template <class T> void operator()(const char* key, T& member) {
    const YAML::Node value = map[key];
    if (!value.IsDefined()) return;  // absent: keep the default
    readValue(value, member, section + "." + key, origin);
  }
};

// Keys that moved to another section: an old config is told where the key is now (rather than
// "did you mean" a key of the old section).
struct MovedKey {
  const char* old_key;
  const char* new_key;
};
constexpr MovedKey kMovedKeys[] = {{"tracking.depth_baseline", "camera.depth_baseline"}};

// Reads one section's YAML map into its options struct, rejecting unknown keys.
template <class Section> void readSection(const YAML::Node& map, Section& section, const Origin& origin) {
  const std::string name = Section::kSection;
  if (map.IsNull()) return;  // "orb:" with nothing under it: all defaults
  if (!map.IsMap())
    throw ConfigError(origin.at(map) + ": config section " + name + " must be a map of 'key: value' lines, got " +
                      shown(map));
  const std::vector<std::string> known = keysOf(section);
  for (const auto& item : map) {
    const std::string key = keyName(item.first, origin, name);
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    for (const MovedKey& moved : kMovedKeys)
      if (name + "." + key == moved.old_key)
        throw ConfigError(origin.at(item.first) + ": config key " + moved.old_key + " is now " + moved.new_key +
                          ": move it there");
    throw ConfigError(origin.at(item.first) + ": unknown config key " + name + "." + key + ": did you mean " + name +
                      "." + closest(key, known) + "? (keys of " + name + ": " + joined(known) + ")");
  }
  SectionReader reader{map, name, origin};
  section.fields(reader);
}

std::vector<std::string> sectionNames(SystemOptions& options) {
  std::vector<std::string> names;
  options.sections([&](auto& s) { names.emplace_back(std::decay_t<decltype(s)>::kSection); });
  return names;
}

// Reads every section present in a top-level YAML map.
void readSystem(const YAML::Node& root, SystemOptions& options, const Origin& origin) {
  const std::vector<std::string> known = sectionNames(options);
  for (const auto& item : root) {
    const std::string name = keyName(item.first, origin, "the top level");
    if (std::find(known.begin(), known.end(), name) == known.end())
      throw ConfigError(origin.at(item.first) + ": unknown config section '" + name + "': did you mean '" +
                        closest(name, known) + "'? (sections: " + joined(known) + ")");
  }
  options.sections([&](auto& section) {
    const YAML::Node map = root[std::decay_t<decltype(section)>::kSection];
    if (map.IsDefined()) readSection(map, section, origin);
  });
}

std::string readConfigFile(const std::filesystem::path& yaml) {
  const std::string file = yaml.string();
  if (!std::filesystem::is_regular_file(yaml))
    throw ConfigError("config file '" + file + "' does not exist: pass a YAML file such as config/tum_fr1.yaml");
  std::ifstream in(yaml, std::ios::binary);
  if (!in) throw ConfigError("cannot read config file '" + file + "': check permissions");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// loadConfigFromString and loadConfigForInput: `intrinsics_given` null means they are required.
SystemOptions loadConfigText(const std::string& text, const std::string& file, bool* intrinsics_given) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(file + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) +
                      ": YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    throw ConfigError("cannot read config file '" + file + "': " + e.what());
  }
  const Origin origin{file};
  rejectDuplicateKeys(root, "", origin);
  if (!root.IsMap() || !root["camera"].IsDefined())
    throw ConfigError(file + ": missing the required 'camera:' section (fx, fy, cx, cy, width, height, distortion, "
                             "depth_factor, fps): start from a preset in config/");
  const YAML::Node camera = root["camera"];
  constexpr const char* kIntrinsics[] = {"fx", "fy", "cx", "cy"};
  const bool none_given = camera.IsMap() && std::none_of(std::begin(kIntrinsics), std::end(kIntrinsics),
                                                         [&](const char* key) { return camera[key].IsDefined(); });
  const bool from_input = intrinsics_given != nullptr && none_given;
  if (!from_input) {
    for (const char* key : kIntrinsics)
      if (!camera.IsMap() || !camera[key].IsDefined())
        throw ConfigError(origin.at(camera) + ": missing config key camera." + key +
                          ": the intrinsics fx, fy, cx, cy have no default (see config/ presets)" +
                          (intrinsics_given != nullptr ? "; leave out all four to take them from a ROS bag's "
                                                         "camera_info"
                                                       : ""));
  } else {
    // The camera's geometry comes from one place: the config or the input, never half of each.
    for (const char* key : {"width", "height", "distortion"})
      if (camera[key].IsDefined())
        throw ConfigError(origin.at(camera[key]) + ": config key camera." + key +
                          " is given but camera.fx, fy, cx, cy are not: give them all, or leave out all of fx, fy, "
                          "cx, cy, width, height and distortion to take them from the input's camera_info");
  }
  if (intrinsics_given != nullptr) *intrinsics_given = !from_input;

  SystemOptions options;
  readSystem(root, options, origin);
  try {
    if (from_input) {
      // Everything but the camera, which the caller completes from the input and validates.
      options.sections([](auto& section) {
        if constexpr (!std::is_same_v<std::decay_t<decltype(section)>, CameraOptions>) section.validate();
      });
    } else {
      options.validate();
    }
  } catch (const ConfigError& e) {
    throw ConfigError(file + ": " + e.what());
  }
  return options;
}

}  // namespace

SystemOptions loadConfig(const std::filesystem::path& yaml) {
  return loadConfigFromString(readConfigFile(yaml), yaml.string());
}

SystemOptions loadConfigFromString(const std::string& text, const std::string& file) {
  return loadConfigText(text, file, nullptr);
}

ConfigForInput loadConfigForInput(const std::filesystem::path& yaml) {
  ConfigForInput config;
  config.options = loadConfigText(readConfigFile(yaml), yaml.string(), &config.intrinsics_given);
  return config;
}

void useInputCalibration(CameraOptions& camera, const InputCalibration& calibration) {
  camera.fx = calibration.fx;
  camera.fy = calibration.fy;
  camera.cx = calibration.cx;
  camera.cy = calibration.cy;
  camera.width = calibration.width;
  camera.height = calibration.height;
  camera.distortion = calibration.distortion;
}

void applyOverride(SystemOptions& options, const std::string& assignment) {
  const Origin origin{"--set '" + assignment + "'", false};
  const auto eq = assignment.find('=');
  const auto dot = assignment.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq)
    throw ConfigError(origin.source + ": expected section.key=value, e.g. dynamic.mode=geometric");
  auto trim = [](std::string s) {
    const auto b = s.find_first_not_of(" \t");
    const auto e = s.find_last_not_of(" \t");
    return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
  };
  const std::string section = trim(assignment.substr(0, dot));
  const std::string key = trim(assignment.substr(dot + 1, eq - dot - 1));
  const std::string value_text = assignment.substr(eq + 1);

  YAML::Node value;
  try {
    value = YAML::Load(value_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(origin.source + ": cannot read the value as YAML: " + e.msg);
  }
  // The same reader as for files, on a one-key document, so checks and messages match.
  YAML::Node root;
  root[section][key] = value;
  readSystem(root, options, origin);
}

nlohmann::json optionsToJson(SystemOptions& options) {
  nlohmann::json out = nlohmann::json::object();
  options.sections([&](auto& section) {
    nlohmann::json& entries = out[std::decay_t<decltype(section)>::kSection];
    entries = nlohmann::json::object();
    auto write = [&](const char* key, const auto& member) {
      if constexpr (NamedEnum<std::decay_t<decltype(member)>>)
        entries[key] = nameOf(member);  // the name a config file uses, not the enum's number
      else
        entries[key] = member;
    };
    section.fields(write);
  });
  return out;
}

}  // namespace desslam::io
