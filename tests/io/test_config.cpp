#include "io/config.hpp"

#include <string>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "support/temp_dir.hpp"
#include "support/expect_contains.hpp"
#include "support/shared_data.hpp"

namespace desslam::io {
namespace {

using test::TempDir;
namespace fs = std::filesystem;

template <class F> std::string configErrorOf(F&& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a ConfigError";
  return {};
}

const char* kCamera =
    "camera:\n"
    "  fx: 500\n"
    "  fy: 501\n"
    "  cx: 320\n"
    "  cy: 240\n";

fs::path preset(const std::string& name) { return test::sourceDir() / "config" / name; }

TEST(Config, PresetsLoadWithTheDatasetIntrinsics) {
  const SystemOptions fr1 = loadConfig(preset("tum_fr1.yaml"));
  EXPECT_DOUBLE_EQ(fr1.camera.fx, 517.306408);
  EXPECT_DOUBLE_EQ(fr1.camera.cy, 255.313989);
  EXPECT_DOUBLE_EQ(fr1.camera.distortion[0], 0.262383);
  EXPECT_DOUBLE_EQ(fr1.camera.distortion[4], 1.163314);

  const SystemOptions fr2 = loadConfig(preset("tum_fr2.yaml"));
  EXPECT_DOUBLE_EQ(fr2.camera.fy, 521.007327);
  EXPECT_DOUBLE_EQ(fr2.camera.distortion[3], -0.000105);

  const SystemOptions fr3 = loadConfig(preset("tum_fr3.yaml"));
  EXPECT_DOUBLE_EQ(fr3.camera.fx, 535.4);
  EXPECT_DOUBLE_EQ(fr3.camera.distortion[0], 0.0);

  const SystemOptions bonn = loadConfig(preset("bonn.yaml"));
  EXPECT_DOUBLE_EQ(bonn.camera.cx, 315.593520);

  for (const SystemOptions* o : {&fr1, &fr2, &fr3, &bonn}) {
    EXPECT_EQ(o->camera.width, 640);
    EXPECT_EQ(o->camera.height, 480);
    EXPECT_DOUBLE_EQ(o->camera.depth_factor, 5000);
    EXPECT_DOUBLE_EQ(o->camera.fps, 30);
    EXPECT_NO_THROW(o->validate());
  }
}

TEST(Config, OmittedSectionsAndKeysKeepDefaults) {
  TempDir dir;
  const auto file = dir.write("c.yaml", std::string(kCamera) + "orb:\n  num_features: 1500\ndense:\n");
  const SystemOptions o = loadConfig(file);
  const SystemOptions defaults;
  EXPECT_EQ(o.orb.num_features, 1500);
  EXPECT_EQ(o.orb.num_levels, defaults.orb.num_levels);
  EXPECT_EQ(o.camera.width, 640);
  EXPECT_EQ(o.dynamic.mode, defaults.dynamic.mode);
  EXPECT_EQ(o.dense.voxel_size, defaults.dense.voxel_size);
  EXPECT_EQ(o.semantic.dynamic_classes, defaults.semantic.dynamic_classes);
}

TEST(Config, ReadsEveryValueType) {
  TempDir dir;
  const auto file = dir.write("c.yaml", std::string(kCamera) +
                                            "  distortion: [0.1, -0.2, 0.001, 0.002, 0.3]\n"
                                            "mapping:\n  local_ba: false\n"
                                            "dynamic:\n  mode: geometric\n  stage1_threshold: 0.15\n"
                                            "semantic:\n  dynamic_classes: [15, 12]\n  model_path:\n");
  const SystemOptions o = loadConfig(file);
  EXPECT_DOUBLE_EQ(o.camera.distortion[2], 0.001);
  EXPECT_FALSE(o.mapping.local_ba);
  EXPECT_EQ(o.dynamic.mode, DynamicMode::kGeometric);
  EXPECT_DOUBLE_EQ(o.dynamic.stage1_threshold, 0.15);
  EXPECT_EQ(o.semantic.dynamic_classes, (std::vector<int>{15, 12}));
  EXPECT_TRUE(o.semantic.model_path.empty());
}

TEST(Config, UnknownKeyNamesItAndSuggestsTheClosest) {
  TempDir dir;
  const auto file = dir.write("typo.yaml", std::string(kCamera) + "orb:\n  num_feature: 1500\n");
  const std::string msg = configErrorOf([&] { loadConfig(file); });
  EXPECT_CONTAINS(msg, "typo.yaml:7");
  EXPECT_CONTAINS(msg, "orb.num_feature");
  EXPECT_CONTAINS(msg, "did you mean orb.num_features");
}

TEST(Config, UnknownSectionSuggestsTheClosest) {
  TempDir dir;
  const auto file = dir.write("sec.yaml", std::string(kCamera) + "trackng:\n  min_inliers: 20\n");
  const std::string msg = configErrorOf([&] { loadConfig(file); });
  EXPECT_CONTAINS(msg, "sec.yaml");
  EXPECT_CONTAINS(msg, "'trackng'");
  EXPECT_CONTAINS(msg, "did you mean 'tracking'");
}

TEST(Config, WrongTypeNamesTheKeyAndTheExpectedType) {
  TempDir dir;
  const std::string number = configErrorOf([&] {
    loadConfig(dir.write("a.yaml", "camera:\n  fx: fast\n  fy: 1\n  cx: 1\n  cy: 1\n"));
  });
  EXPECT_CONTAINS(number, "a.yaml:2");
  EXPECT_CONTAINS(number, "camera.fx");
  EXPECT_CONTAINS(number, "expected a number");

  const std::string integer = configErrorOf([&] { loadConfig(dir.write("b.yaml", std::string(kCamera) + "orb:\n  num_levels: 2.5\n")); });
  EXPECT_CONTAINS(integer, "orb.num_levels");
  EXPECT_CONTAINS(integer, "expected an integer");

  const std::string boolean = configErrorOf([&] { loadConfig(dir.write("c.yaml", std::string(kCamera) + "dense:\n  enabled: maybe\n")); });
  EXPECT_CONTAINS(boolean, "dense.enabled");
  EXPECT_CONTAINS(boolean, "true or false");

  const std::string list = configErrorOf([&] { loadConfig(dir.write("d.yaml", std::string(kCamera) + "  distortion: [1, 2, 3]\n")); });
  EXPECT_CONTAINS(list, "camera.distortion");
  EXPECT_CONTAINS(list, "list of 5 numbers");

  const std::string element = configErrorOf([&] { loadConfig(dir.write("e.yaml", std::string(kCamera) + "semantic:\n  dynamic_classes: [15, person]\n")); });
  EXPECT_CONTAINS(element, "semantic.dynamic_classes[1]");

  const std::string section = configErrorOf([&] { loadConfig(dir.write("f.yaml", std::string(kCamera) + "orb: 7\n")); });
  EXPECT_CONTAINS(section, "f.yaml");
  EXPECT_CONTAINS(section, "orb");
}

TEST(Config, BadValueFailsValidationNamingFileAndKey) {
  TempDir dir;
  const std::string range = configErrorOf([&] { loadConfig(dir.write("r.yaml", std::string(kCamera) + "tracking:\n  min_inliers: 1\n")); });
  EXPECT_CONTAINS(range, "r.yaml");
  EXPECT_CONTAINS(range, "tracking.min_inliers");

  const std::string mode = configErrorOf([&] { loadConfig(dir.write("m.yaml", std::string(kCamera) + "dynamic:\n  mode: magic\n")); });
  EXPECT_CONTAINS(mode, "m.yaml:7");
  EXPECT_CONTAINS(mode, "dynamic.mode");
  EXPECT_CONTAINS(mode, "magic");
  EXPECT_CONTAINS(mode, "off, semantic, geometric, full");
}

TEST(Config, MovedKeySaysWhereItIsNow) {
  SystemOptions o = loadConfig(preset("tum_fr1.yaml"));
  const std::string moved = configErrorOf([&] { applyOverride(o, "tracking.depth_baseline=0.1"); });
  EXPECT_CONTAINS(moved, "tracking.depth_baseline is now camera.depth_baseline");
  applyOverride(o, "camera.depth_baseline=0.1");
  EXPECT_DOUBLE_EQ(o.camera.bf(), 517.306408 * 0.1);
  applyOverride(o, "matching.ratio=0.7");
  EXPECT_DOUBLE_EQ(o.matching.ratio, 0.7);
  EXPECT_EQ(optionsToJson(o)["matching"]["ratio"], 0.7);
}

// Every mode option is read by name: an unknown name lists the allowed ones and the closest, in a
// file and on the command line; a known name sets the enum.
TEST(Config, ModeNamesAreReadAndUnknownOnesListTheAllowedValues) {
  struct Case {
    const char* section;
    const char* key;
    const char* typo;
    const char* suggestion;
    const char* allowed;
  };
  for (const Case& c : {Case{"dynamic", "mode", "geometirc", "geometric", "off, semantic, geometric, full"},
                        Case{"dynamic", "stage1_unmatched_policy", "dorp", "drop", "keep, drop"},
                        Case{"semantic", "segmenter", "maskdir", "mask_dir", "deeplab, mask_dir, none"},
                        Case{"semantic", "backend", "openvc", "opencv", "opencv, xnnpack"}}) {
    const std::string key = std::string(c.section) + "." + c.key;
    SystemOptions o = loadConfig(preset("tum_fr1.yaml"));
    const std::string message = configErrorOf([&] { applyOverride(o, key + "=" + c.typo); });
    EXPECT_CONTAINS(message, "--set");
    EXPECT_CONTAINS(message, key);
    EXPECT_CONTAINS(message, c.typo);
    EXPECT_CONTAINS(message, std::string("did you mean '") + c.suggestion + "'");
    EXPECT_CONTAINS(message, c.allowed);
    const std::string list = configErrorOf([&] { applyOverride(o, key + "=[a, b]"); });
    EXPECT_CONTAINS(list, "expected one of " + std::string(c.allowed));
    applyOverride(o, key + "=" + c.suggestion);
    EXPECT_EQ(optionsToJson(o)[c.section][c.key], c.suggestion);
  }
  SystemOptions o = loadConfig(preset("tum_fr1.yaml"));
  applyOverride(o, "dynamic.stage1_unmatched_policy=keep");
  applyOverride(o, "semantic.segmenter=none");
  applyOverride(o, "semantic.backend=opencv");
  EXPECT_EQ(o.dynamic.stage1_unmatched_policy, UnmatchedPolicy::kKeep);
  EXPECT_EQ(o.semantic.segmenter, SegmenterKind::kNone);
  EXPECT_EQ(o.semantic.backend, SegmentationBackend::kOpenCv);
}

TEST(Config, CameraSectionAndIntrinsicsAreRequired) {
  TempDir dir;
  const std::string no_camera = configErrorOf([&] { loadConfig(dir.write("n.yaml", "orb:\n  num_features: 900\n")); });
  EXPECT_CONTAINS(no_camera, "n.yaml");
  EXPECT_CONTAINS(no_camera, "camera");

  const std::string empty = configErrorOf([&] { loadConfig(dir.write("empty.yaml", "")); });
  EXPECT_CONTAINS(empty, "empty.yaml");

  const std::string no_cy = configErrorOf([&] { loadConfig(dir.write("cy.yaml", "camera:\n  fx: 1\n  fy: 1\n  cx: 1\n")); });
  EXPECT_CONTAINS(no_cy, "cy.yaml");
  EXPECT_CONTAINS(no_cy, "camera.cy");
}

TEST(Config, MissingFileAndSyntaxErrorNameTheFile) {
  TempDir dir;
  const std::string missing = configErrorOf([&] { loadConfig(dir.path() / "nope.yaml"); });
  EXPECT_CONTAINS(missing, "nope.yaml");

  const auto bad = dir.write("bad.yaml", std::string(kCamera) + "orb:\n  num_features: [1, 2\n");
  const std::string syntax = configErrorOf([&] { loadConfig(bad); });
  EXPECT_CONTAINS(syntax, "bad.yaml:");
  EXPECT_CONTAINS(syntax, "syntax");
}

TEST(Config, OverrideSetsValuesOfEveryType) {
  SystemOptions o = loadConfig(preset("tum_fr1.yaml"));
  applyOverride(o, "dynamic.mode=geometric");
  applyOverride(o, "orb.num_features=2000");
  applyOverride(o, "tracking.max_depth = 5.5");
  applyOverride(o, "mapping.local_ba=false");
  applyOverride(o, "camera.distortion=[0,0,0,0,0]");
  applyOverride(o, "semantic.dynamic_classes=[15, 8]");
  applyOverride(o, "semantic.model_path=/models/a b.onnx");
  EXPECT_EQ(o.dynamic.mode, DynamicMode::kGeometric);
  EXPECT_EQ(o.orb.num_features, 2000);
  EXPECT_DOUBLE_EQ(o.tracking.max_depth, 5.5);
  EXPECT_FALSE(o.mapping.local_ba);
  EXPECT_DOUBLE_EQ(o.camera.distortion[0], 0.0);
  EXPECT_EQ(o.semantic.dynamic_classes, (std::vector<int>{15, 8}));
  EXPECT_EQ(o.semantic.model_path, "/models/a b.onnx");
  EXPECT_DOUBLE_EQ(o.camera.fx, 517.306408);  // untouched
  EXPECT_NO_THROW(o.validate());
}

TEST(Config, BadOverrideNamesTheKey) {
  SystemOptions o = loadConfig(preset("tum_fr1.yaml"));
  const std::string unknown = configErrorOf([&] { applyOverride(o, "dynamic.moed=off"); });
  EXPECT_CONTAINS(unknown, "dynamic.moed");
  EXPECT_CONTAINS(unknown, "dynamic.mode");
  EXPECT_CONTAINS(unknown, "--set");

  const std::string type = configErrorOf([&] { applyOverride(o, "orb.num_levels=many"); });
  EXPECT_CONTAINS(type, "orb.num_levels");
  EXPECT_CONTAINS(type, "expected an integer");

  EXPECT_THROW(applyOverride(o, "dynamic.mode"), ConfigError);
  EXPECT_THROW(applyOverride(o, "mode=off"), ConfigError);
  EXPECT_THROW(applyOverride(o, "nosection.mode=off"), ConfigError);
  EXPECT_EQ(o.orb.num_levels, SystemOptions().orb.num_levels);  // failed overrides change nothing
}

TEST(Config, JsonHoldsEverySectionAndKeyAndReloadsToTheSameOptions) {
  SystemOptions o = loadConfig(preset("tum_fr1.yaml"));
  applyOverride(o, "dynamic.mode=semantic");
  const nlohmann::json j = optionsToJson(o);
  for (const char* section : {"camera", "orb", "tracking", "mapping", "dynamic", "semantic", "dense"})
    EXPECT_TRUE(j.contains(section)) << section;
  EXPECT_DOUBLE_EQ(j["camera"]["fx"].get<double>(), 517.306408);
  EXPECT_EQ(j["camera"]["distortion"].size(), 5u);
  EXPECT_EQ(j["dynamic"]["mode"], "semantic");  // the names, not the enums' numbers
  EXPECT_EQ(j["dynamic"]["stage1_unmatched_policy"], "drop");
  EXPECT_EQ(j["semantic"]["segmenter"], "deeplab");
  EXPECT_EQ(j["semantic"]["backend"], "xnnpack");
  EXPECT_EQ(j["semantic"]["dynamic_classes"], nlohmann::json::array({15}));
  EXPECT_EQ(j["mapping"]["local_ba"], true);

  // JSON is YAML: the report's settings can be fed back as a config.
  TempDir dir;
  const auto file = dir.write("from_report.yaml", j.dump(2));
  SystemOptions reloaded = loadConfig(file);
  EXPECT_EQ(optionsToJson(reloaded), j);
}

// yaml-cpp keeps both entries of a repeated key but a lookup sees one: a silently ignored value.
TEST(Config, DuplicateKeysAndSectionsNameBothLines) {
  TempDir dir;
  // kCamera is lines 1-5.
  const std::string key = configErrorOf(
      [&] { loadConfig(dir.write("k.yaml", std::string(kCamera) + "tracking:\n  max_depth: 3.0\n  min_depth: 0.2\n  max_depth: 3.5\n")); });
  EXPECT_CONTAINS(key, "k.yaml");
  EXPECT_CONTAINS(key, "duplicate config key tracking.max_depth");
  EXPECT_CONTAINS(key, "line 7");
  EXPECT_CONTAINS(key, "line 9");

  const std::string section = configErrorOf(
      [&] { loadConfig(dir.write("s.yaml", std::string(kCamera) + "orb:\n  num_features: 900\norb:\n  num_levels: 4\n")); });
  EXPECT_CONTAINS(section, "duplicate config section 'orb'");
  EXPECT_CONTAINS(section, "line 6");
  EXPECT_CONTAINS(section, "line 8");

  const std::string camera_key = configErrorOf([&] { loadConfig(dir.write("c.yaml", std::string(kCamera) + "  fx: 520\n")); });
  EXPECT_CONTAINS(camera_key, "camera.fx");
  EXPECT_CONTAINS(camera_key, "line 2");
  EXPECT_CONTAINS(camera_key, "line 6");

  // Flow style too.
  const std::string flow = configErrorOf(
      [&] { loadConfig(dir.write("f.yaml", std::string(kCamera) + "dense: {voxel_size: 0.02, voxel_size: 0.03}\n")); });
  EXPECT_CONTAINS(flow, "dense.voxel_size");
}

TEST(Config, KeysThatAreNotNamesAreRejected) {
  TempDir dir;
  const std::string complex = configErrorOf([&] { loadConfig(dir.write("x.yaml", std::string(kCamera) + "? [a, b]\n: 1\n")); });
  EXPECT_CONTAINS(complex, "x.yaml");
  EXPECT_CONTAINS(complex, "plain name");
}

TEST(Config, ImplausibleFocalLengthIsNamed) {
  TempDir dir;
  for (const char* fx : {"1e-9", "1e300", "5", "100000"}) {
    SCOPED_TRACE(fx);
    const std::string message = configErrorOf([&] {
      loadConfig(dir.write("fx.yaml", "camera:\n  fx: " + std::string(fx) + "\n  fy: 500\n  cx: 320\n  cy: 240\n"));
    });
    EXPECT_CONTAINS(message, "camera.fx");
    EXPECT_CONTAINS(message, "field of view");
  }
  const std::string nan = configErrorOf(
      [&] { loadConfig(dir.write("nan.yaml", "camera:\n  fx: .nan\n  fy: 500\n  cx: 320\n  cy: 240\n")); });
  EXPECT_CONTAINS(nan, "camera.fx");
}

// `desslam run` on a ROS bag: the camera may come from the bag's camera_info.
TEST(Config, IntrinsicsMayBeLeftOutOnlyAllTogetherForAnInputWithCalibration) {
  TempDir dir;
  const auto none = dir.write("none.yaml", "camera:\n  fps: 30\ntracking:\n  max_depth: 3.5\n");
  ConfigForInput config = loadConfigForInput(none);
  EXPECT_FALSE(config.intrinsics_given);
  EXPECT_EQ(config.options.camera.fx, 0.0);
  EXPECT_DOUBLE_EQ(config.options.tracking.max_depth, 3.5);
  // The other sections are still validated.
  const std::string other = configErrorOf(
      [&] { loadConfigForInput(dir.write("o.yaml", "camera:\n  fps: 30\norb:\n  num_levels: 0\n")); });
  EXPECT_CONTAINS(other, "orb.num_levels");
  // Completed from the input, the options validate.
  InputCalibration calibration;
  calibration.fx = 525;
  calibration.fy = 525;
  calibration.cx = 319.5;
  calibration.cy = 239.5;
  calibration.width = 640;
  calibration.height = 480;
  calibration.distortion = {0.1, 0, 0, 0, 0};
  useInputCalibration(config.options.camera, calibration);
  EXPECT_NO_THROW(config.options.validate());
  EXPECT_EQ(config.options.camera.distortion[0], 0.1);

  // Given: as loadConfig.
  const auto given = dir.write("given.yaml", kCamera);
  EXPECT_TRUE(loadConfigForInput(given).intrinsics_given);
  EXPECT_DOUBLE_EQ(loadConfigForInput(given).options.camera.fx, loadConfig(given).camera.fx);
  // Half given: an error naming the missing key, saying how to leave them all out.
  const std::string half = configErrorOf(
      [&] { loadConfigForInput(dir.write("half.yaml", "camera:\n  fx: 500\n  fy: 500\n")); });
  EXPECT_CONTAINS(half, "camera.cx");
  EXPECT_CONTAINS(half, "camera_info");
  // No intrinsics but a size or distortion: the camera comes from one place.
  const std::string size = configErrorOf(
      [&] { loadConfigForInput(dir.write("size.yaml", "camera:\n  width: 320\n")); });
  EXPECT_CONTAINS(size, "size.yaml");
  EXPECT_CONTAINS(size, "camera.width");
  // loadConfig itself still requires them.
  EXPECT_CONTAINS(configErrorOf([&] { loadConfig(none); }), "camera.fx");
}

}  // namespace
}  // namespace desslam::io
