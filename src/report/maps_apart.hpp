// What a user must be told when a run ends with maps that were never merged into the main map:
// their frames have poses, but not in CameraTrajectory.txt nor in its ATE.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace desslam::report {

// From report.json's "statistics" (counts.frames, atlas.frames_outside_main_map,
// atlas.maps_apart_from_main, atlas.frames_in_main_map): one line naming how many frames lie in
// which maps apart from the main map and where they are, or nothing when every frame with a
// pose is in the main map (or the statistics lack these fields).
std::optional<std::string> mapsApartWarning(const nlohmann::json& statistics);

}  // namespace desslam::report
