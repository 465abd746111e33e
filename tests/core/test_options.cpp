// Options: defaults validate, and every rejection names the offending "section.key".
#include "system/system_options.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.hpp"

namespace desslam {
namespace {

SystemOptions validDefaults() {
  SystemOptions o;
  o.camera.fx = 525;
  o.camera.fy = 525;
  o.camera.cx = 319.5;
  o.camera.cy = 239.5;
  return o;
}

// The ConfigError message of validate() after `change`, or "" when nothing was thrown.
std::string errorAfter(const std::function<void(SystemOptions&)>& change) {
  SystemOptions o = validDefaults();
  change(o);
  try {
    o.validate();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return {};
}

#define EXPECT_REJECTED_NAMING(change, key)                                                  \
  do {                                                                                       \
    const std::string message = errorAfter(change);                                          \
    EXPECT_FALSE(message.empty()) << "validate() accepted a bad " << (key);                 \
    EXPECT_NE(message.find(key), std::string::npos) << "'" << message << "' lacks " << (key); \
  } while (0)

TEST(Options, DefaultsWithIntrinsicsValidate) { EXPECT_NO_THROW(validDefaults().validate()); }

TEST(Options, CameraWithoutIntrinsicsIsRejected) {
  SystemOptions o;  // fx = fy = 0
  EXPECT_THROW(o.validate(), ConfigError);
}

TEST(Options, OrbNumLevelsZeroNamesTheKey) {
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.orb.num_levels = 0; }, "orb.num_levels");
}

TEST(Options, MessageShowsTheBadValue) {
  const std::string message = errorAfter([](SystemOptions& o) { o.orb.scale_factor = 3.5; });
  EXPECT_NE(message.find("orb.scale_factor"), std::string::npos) << message;
  EXPECT_NE(message.find("3.5"), std::string::npos) << message;
}

TEST(Options, EachSectionNamesItsKey) {
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.fx = -1; }, "camera.fx");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.width = 0; }, "camera.width");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.cx = 5000; }, "camera.cx");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.depth_factor = 0; }, "camera.depth_factor");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.fps = 0; }, "camera.fps");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.orb.num_features = 0; }, "orb.num_features");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.orb.min_fast_threshold = 30; }, "orb.min_fast_threshold");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.tracking.max_depth = 0.05; }, "tracking.max_depth");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.tracking.min_inliers = 0; }, "tracking.min_inliers");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.tracking.keyframe_tracked_ratio = 1.5; },
                         "tracking.keyframe_tracked_ratio");
  // 0 turns it off; between 0 and 1 a pose found again with fewer inliers than the bridge's frames would overrule it.
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.tracking.bridge_overruled_inlier_ratio = 0.5; },
                         "tracking.bridge_overruled_inlier_ratio");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.mapping.local_ba_iterations = 0; },
                         "mapping.local_ba_iterations");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.dynamic.stage1_threshold = -0.1; }, "dynamic.stage1_threshold");
  EXPECT_REJECTED_NAMING(
      [](SystemOptions& o) {
        o.semantic.segmenter = SegmenterKind::kMaskDir;
        o.semantic.mask_dir.clear();
      },
      "semantic.mask_dir");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.semantic.dynamic_classes.clear(); }, "semantic.dynamic_classes");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.dense.voxel_size = 0; }, "dense.voxel_size");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.dense.pixel_stride = 0; }, "dense.pixel_stride");
}

TEST(Options, DynamicModesAreAccepted) {
  for (DynamicMode mode : {DynamicMode::kOff, DynamicMode::kSemantic, DynamicMode::kGeometric, DynamicMode::kFull}) {
    EXPECT_EQ(errorAfter([&](SystemOptions& o) { o.dynamic.mode = mode; }), "") << nameOf(mode);
  }
}

// The names a config file uses; each enum value has its own, and each name parses back to it.
template <class E> void expectNamesRoundTrip(const std::vector<std::string>& expected) {
  EXPECT_EQ(enumNameList<E>(), expected);
  for (const std::string& name : expected) {
    const std::optional<E> value = enumFromName<E>(name);
    ASSERT_TRUE(value.has_value()) << name;
    EXPECT_EQ(nameOf(*value), name);
  }
  EXPECT_FALSE(enumFromName<E>("").has_value());
  EXPECT_FALSE(enumFromName<E>(expected.front() + "x").has_value());
}

TEST(Options, ModeNamesRoundTrip) {
  expectNamesRoundTrip<DynamicMode>({"off", "semantic", "geometric", "full"});
  expectNamesRoundTrip<UnmatchedPolicy>({"keep", "drop"});
  expectNamesRoundTrip<SegmenterKind>({"deeplab", "mask_dir", "none"});
  expectNamesRoundTrip<SegmentationBackend>({"opencv", "xnnpack"});
  EXPECT_TRUE(usesMask(DynamicMode::kSemantic) && usesMask(DynamicMode::kFull));
  EXPECT_FALSE(usesMask(DynamicMode::kOff) || usesMask(DynamicMode::kGeometric));
  EXPECT_TRUE(usesDepthChecks(DynamicMode::kGeometric) && usesDepthChecks(DynamicMode::kFull));
  EXPECT_FALSE(usesDepthChecks(DynamicMode::kOff) || usesDepthChecks(DynamicMode::kSemantic));
}

TEST(Options, StereoBaselineComesFromTheCamera) {
  SystemOptions o = validDefaults();
  o.camera.depth_baseline = 0.075;
  EXPECT_DOUBLE_EQ(o.camera.bf(), 525 * 0.075);
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.depth_baseline = 0; }, "camera.depth_baseline");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.matching.strict_distance = 200; }, "matching.strict_distance");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.matching.ratio = 0; }, "matching.ratio");
}

TEST(Options, MethodThresholdsAreTheDefaults) {
  // DeS-SLAM's stage thresholds (12 % and 8 %) and the TUM/Bonn depth factor.
  const SystemOptions o;
  EXPECT_DOUBLE_EQ(o.dynamic.stage1_threshold, 0.12);
  EXPECT_DOUBLE_EQ(o.dynamic.stage2_threshold, 0.08);
  EXPECT_DOUBLE_EQ(o.camera.depth_factor, 5000.0);
}

// fields() lists each key once: the loader, report and unknown-key detection rely on it.
struct KeyCollector {
  std::vector<std::string> keys;
  template <class T> void operator()(const char* key, T&) { keys.emplace_back(key); }
};

TEST(Options, FieldListsHaveUniqueKeysAndSections) {
  SystemOptions o = validDefaults();
  std::vector<std::string> sections;
  o.sections([&](auto& section) {
    sections.emplace_back(std::decay_t<decltype(section)>::kSection);
    KeyCollector collector;
    section.fields(collector);
    EXPECT_FALSE(collector.keys.empty()) << sections.back();
    std::vector<std::string> sorted = collector.keys;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end())
        << "duplicate key in section " << sections.back();
  });
  const std::vector<std::string> expected{"camera", "orb", "tracking", "mapping", "dynamic", "semantic", "dense"};
  // Sections may be added later; these must stay (config files use them).
  for (const std::string& name : expected)
    EXPECT_NE(std::find(sections.begin(), sections.end(), name), sections.end()) << name;
  std::vector<std::string> sorted = sections;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end()) << "duplicate section";
}

// Every numeric option of every section is range-checked: a huge, a hugely negative and (for
// doubles) a NaN value are each rejected by validate() with a message naming "section.key".
struct BadValueProbe {
  std::string section;
  std::vector<std::string> problems;
  template <class T> void operator()(const char* key, T& member) {
    if constexpr (std::is_same_v<T, double> || std::is_same_v<T, int>) {
      std::vector<T> bad_values;
      if constexpr (std::is_same_v<T, double>)
        bad_values = {1e300, -1e300, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()};
      else
        bad_values = {std::numeric_limits<int>::max(), std::numeric_limits<int>::min()};
      const T saved = member;
      for (T bad : bad_values) {
        member = bad;
        std::string message;
        try {
          validate();
        } catch (const ConfigError& e) {
          message = e.what();
        }
        const std::string name = section + "." + key;
        if (message.find(name) == std::string::npos)
          problems.push_back(name + " = " + std::to_string(bad) + ": " + (message.empty() ? "accepted" : message));
      }
      member = saved;
    }
  }
  std::function<void()> validate;
};

TEST(Options, EveryNumericOptionIsRangeChecked) {
  SystemOptions o = validDefaults();
  std::vector<std::string> problems;
  o.sections([&](auto& section) {
    BadValueProbe probe{std::decay_t<decltype(section)>::kSection, {}, [&] { o.validate(); }};
    section.fields(probe);
    problems.insert(problems.end(), probe.problems.begin(), probe.problems.end());
  });
  for (const std::string& p : problems) ADD_FAILURE() << p;
  // The distortion coefficients too.
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.distortion[2] = std::nan(""); }, "camera.distortion");
}

TEST(Options, FocalLengthMustGiveAPlausibleFieldOfView) {
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.fx = o.camera.fy = 1e-9; }, "camera.fx");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.fx = o.camera.fy = 1e300; }, "camera.fx");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.fx = o.camera.fy = 20; }, "camera.fx");  // 173 degrees
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.fx = o.camera.fy = 2000; }, "camera.fx");  // 18 degrees
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.camera.fy = 2000; }, "camera.fy");
  EXPECT_NO_THROW([] { SystemOptions o = validDefaults(); o.camera.fx = o.camera.fy = 200; o.validate(); }());
}

TEST(Options, BagTopicsMustBeFullTopicNames) {
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.bag.rgb_topic = "camera/rgb/image_color"; }, "bag.rgb_topic");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.bag.depth_topic = ""; }, "bag.depth_topic");
  EXPECT_REJECTED_NAMING([](SystemOptions& o) { o.bag.camera_info_topic = "/camera/rgb info"; }, "bag.camera_info_topic");
  EXPECT_NO_THROW([] { SystemOptions o = validDefaults(); o.bag.depth_topic = "/kinect/depth/image_raw"; o.validate(); }());
}

}  // namespace
}  // namespace desslam
