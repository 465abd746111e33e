// Configuration: one YAML file, one section per options struct (camera, orb, tracking, mapping,
// dynamic, semantic, dense). Sections and keys come from each struct's fields() list, so a new
// option needs no code here. Sections/keys may be omitted (defaults apply) except `camera:`,
// whose fx, fy, cx, cy have no sensible default (unless the input gives them: loadConfigForInput).
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "io/rgbd_sequence.hpp"
#include "system/system_options.hpp"

namespace desslam::io {

// Loads and validates a config. Throws ConfigError naming the file and "section.key" for: missing
// file, YAML syntax error (with line), unknown section or key (with the closest known one),
// wrong type ("expected a number"), missing camera section/intrinsics, failed validation.
// A key or section given twice is an error naming both lines (YAML itself would keep one silently).
SystemOptions loadConfig(const std::filesystem::path& yaml);
// The same for a document in memory; `file` names it in messages.
SystemOptions loadConfigFromString(const std::string& text, const std::string& file);

// For inputs that may carry their own calibration (a ROS bag's camera_info; `desslam run`): as
// loadConfig, but the camera section may leave out all of fx, fy, cx, cy (and then also width,
// height and distortion: the camera's geometry comes from one place). Then `intrinsics_given` is
// false, those keys keep their defaults (fx..cy 0) and the camera section is not validated: the
// caller takes them from the input (useInputCalibration) and calls options.validate().
struct ConfigForInput {
  SystemOptions options;
  bool intrinsics_given = true;
};
ConfigForInput loadConfigForInput(const std::filesystem::path& yaml);

// Sets camera.fx, fy, cx, cy, width, height and distortion from the input's calibration.
void useInputCalibration(CameraOptions& camera, const InputCalibration& calibration);

// Applies one "section.key=value" assignment (the command line's --set), e.g.
// "dynamic.mode=geometric", "camera.distortion=[0,0,0,0,0]". The value is read as YAML.
// Throws ConfigError naming the assignment on unknown keys or wrong types. Does not validate the
// whole struct (several overrides may only make sense together): call options.validate() after.
void applyOverride(SystemOptions& options, const std::string& assignment);

// Every section and key with its value ({"camera": {"fx": ...}, ...}), for report.json.
// Non-const only because the fields() visitors are; nothing is changed.
nlohmann::json optionsToJson(SystemOptions& options);

}  // namespace desslam::io
