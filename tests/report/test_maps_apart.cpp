// The warning at the end of a run whose maps were not all merged into the main map.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "report/maps_apart.hpp"
#include "support/expect_contains.hpp"

namespace desslam {
namespace {

nlohmann::json statistics(size_t frames, size_t in_main, const nlohmann::json& apart) {
  size_t outside = 0;
  for (const nlohmann::json& m : apart) outside += m["frames"].get<size_t>();
  return {{"counts", {{"frames", frames}}},
          {"atlas", {{"frames_in_main_map", in_main}, {"frames_outside_main_map", outside}, {"maps_apart_from_main", apart}}}};
}

TEST(MapsApartWarning, NamesTheFramesTheMapsAndWhereTheyAre) {
  const auto warning = report::mapsApartWarning(
      statistics(573, 321, {{{"id", 0}, {"frames", 41}}, {{"id", 2}, {"frames", 179}}, {{"id", 4}, {"frames", 32}}}));
  ASSERT_TRUE(warning.has_value());
  EXPECT_CONTAINS(*warning, "252 of 573 frames (44.0 %)");
  EXPECT_CONTAINS(*warning, "3 maps");
  EXPECT_CONTAINS(*warning, "0 (41), 2 (179), 4 (32)");
  EXPECT_CONTAINS(*warning, "CameraTrajectory_all.txt");
  EXPECT_CONTAINS(*warning, "main map's 321 frames");
}

TEST(MapsApartWarning, OneMapApartIsNamedAsOne) {
  const auto warning = report::mapsApartWarning(statistics(100, 90, {{{"id", 1}, {"frames", 10}}}));
  ASSERT_TRUE(warning.has_value());
  EXPECT_CONTAINS(*warning, "10 of 100 frames (10.0 %) have a pose only in a map never merged");
  EXPECT_CONTAINS(*warning, "1 (10)");
}

TEST(MapsApartWarning, NothingWhenEveryFrameIsInTheMainMap) {
  EXPECT_FALSE(report::mapsApartWarning(statistics(100, 100, nlohmann::json::array())).has_value());
  // A report.json from before these fields: nothing to say.
  EXPECT_FALSE(report::mapsApartWarning({{"counts", {{"frames", 100}}}, {"atlas", nlohmann::json::object()}}).has_value());
  EXPECT_FALSE(report::mapsApartWarning(nlohmann::json::object()).has_value());
  EXPECT_FALSE(report::mapsApartWarning(nlohmann::json()).has_value());
  EXPECT_FALSE(report::mapsApartWarning({{"atlas", 3}}).has_value());
}

}  // namespace
}  // namespace desslam
