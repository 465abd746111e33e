#include "report/maps_apart.hpp"

#include <cstdio>

namespace desslam::report {

std::optional<std::string> mapsApartWarning(const nlohmann::json& statistics) {
  if (!statistics.is_object() || !statistics.contains("atlas") || !statistics["atlas"].is_object()) return std::nullopt;
  const nlohmann::json& atlas = statistics["atlas"];
  const size_t outside = atlas.value("frames_outside_main_map", size_t{0});
  if (outside == 0) return std::nullopt;
  const nlohmann::json& counts = statistics.value("counts", nlohmann::json::object());
  const size_t frames = counts.is_object() ? counts.value("frames", size_t{0}) : 0;
  const nlohmann::json apart = atlas.value("maps_apart_from_main", nlohmann::json::array());
  std::string maps;
  for (const nlohmann::json& m : apart) {
    if (!maps.empty()) maps += ", ";
    maps += std::to_string(m.value("id", -1)) + " (" + std::to_string(m.value("frames", size_t{0})) + ")";
  }
  char share[32] = "";
  if (frames > 0) std::snprintf(share, sizeof share, " (%.1f %%)", 100.0 * static_cast<double>(outside) / frames);
  return std::to_string(outside) + " of " + std::to_string(frames) + " frames" + share + " have a pose only in " +
         (apart.size() == 1 ? "a map" : std::to_string(apart.size()) + " maps") +
         " never merged into the main map (map id (frames): " + maps +
         "): CameraTrajectory_all.txt holds them, each in its own map's frame; CameraTrajectory.txt and the "
         "ATE hold the main map's " +
         std::to_string(atlas.value("frames_in_main_map", size_t{0})) + " frames";
}

}  // namespace desslam::report
