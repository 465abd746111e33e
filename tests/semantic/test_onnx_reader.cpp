// The ONNX reader (protobuf wire format parsed directly) on hand-encoded models, on the shared
// DeepLab model, and on broken input; and the XNNPACK backend's error for an unsupported op.
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "semantic/deeplab_common.hpp"
#include "semantic/onnx_reader.hpp"
#include "semantic/segmenter.hpp"
#include "onnx_test_encoder.hpp"
#include "support/shared_data.hpp"
#include "support/temp_dir.hpp"

namespace desslam::semantic::onnx {
namespace {

using namespace test::onnx_encoder;

// A graph with one node of `op` from x [1,3,4,4] to y, plus initializers and attributes.
std::string smallGraph(const std::string& op) {
  const std::string weights = packedInts(1, {2, 3}) + intField(2, kFloat) +
                              packedFloats(4, {1, 2, 3, 4, 5, 6}) + bytesField(8, "w");
  std::string raw(3 * 4, '\0');
  const float raw_values[3] = {0.5f, -1.5f, 2.5f};
  std::memcpy(raw.data(), raw_values, raw.size());
  const std::string raw_tensor = intField(1, 3) + intField(2, kFloat) + bytesField(8, "r") + bytesField(9, raw);
  const std::string int_tensor = intField(1, 2) + intField(2, kInt64) + packedInts(7, {-4, 9}) + bytesField(8, "k");
  const std::string node = bytesField(1, "x") + bytesField(1, "w") + bytesField(2, "y") + bytesField(3, "n0") +
                           bytesField(4, op) +
                           bytesField(5, bytesField(1, "axis") + intField(3, -1) + intField(20, 2)) +
                           bytesField(5, bytesField(1, "alpha") + floatField(2, 0.25f)) +
                           bytesField(5, bytesField(1, "mode") + bytesField(4, "linear")) +
                           bytesField(5, bytesField(1, "pads") + intField(8, 1) + intField(8, 2)) +
                           bytesField(5, bytesField(1, "strides") + packedInts(8, {3, 4}));
  return bytesField(1, node) + bytesField(2, "g") + bytesField(5, weights) + bytesField(5, raw_tensor) +
         bytesField(5, int_tensor) + bytesField(11, valueInfo("x", {1, 3, 4, 4})) +
         bytesField(11, valueInfo("w", {2, 3})) + bytesField(12, valueInfo("y", {1, 3, 4, 4}));
}

TEST(OnnxReader, ReadsNodesAttributesInitializersAndShapes) {
  const Model m = parseModel(model(smallGraph("Softmax")));
  EXPECT_EQ(m.ir_version, 7);
  EXPECT_EQ(m.opset, 11);
  ASSERT_EQ(m.nodes.size(), 1u);
  const Node& n = m.nodes[0];
  EXPECT_EQ(n.op_type, "Softmax");
  EXPECT_EQ(n.name, "n0");
  EXPECT_EQ(n.inputs, (std::vector<std::string>{"x", "w"}));
  EXPECT_EQ(n.outputs, (std::vector<std::string>{"y"}));
  EXPECT_EQ(n.intAttribute("axis", 0), -1);
  EXPECT_FLOAT_EQ(n.floatAttribute("alpha", 0), 0.25f);
  EXPECT_EQ(n.stringAttribute("mode", ""), "linear");
  EXPECT_EQ(n.intsAttribute("pads", {}), (std::vector<std::int64_t>{1, 2}));     // one per key
  EXPECT_EQ(n.intsAttribute("strides", {}), (std::vector<std::int64_t>{3, 4}));  // packed
  EXPECT_EQ(n.intAttribute("missing", 42), 42);
  ASSERT_EQ(m.initializers.count("w"), 1u);
  EXPECT_EQ(m.initializers.at("w").dims, (std::vector<std::int64_t>{2, 3}));
  EXPECT_EQ(m.initializers.at("w").floats, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(m.initializers.at("r").floats, (std::vector<float>{0.5f, -1.5f, 2.5f}));  // raw_data
  EXPECT_EQ(m.initializers.at("k").ints, (std::vector<std::int64_t>{-4, 9}));
  // "w" is listed as an input too (IR < 4 style) but is an initializer: not a graph input.
  ASSERT_EQ(m.inputs.size(), 1u);
  EXPECT_EQ(m.inputs[0].name, "x");
  EXPECT_EQ(m.inputs[0].dims, (std::vector<std::int64_t>{1, 3, 4, 4}));
  ASSERT_EQ(m.outputs.size(), 1u);
  EXPECT_EQ(m.outputs[0].name, "y");
}

// A float tensor with a zero dimension and empty raw_data (the shared DeepLab model has one):
// read as zero values (in the ASan+UBSan build this also checks no null pointer reaches memcpy).
TEST(OnnxReader, ReadsAnEmptyRawFloatTensor) {
  const std::string empty_tensor = packedInts(1, {0}) + intField(2, kFloat) + bytesField(8, "roi") + bytesField(9, "");
  const Model m = parseModel(model(bytesField(5, empty_tensor)));
  ASSERT_EQ(m.initializers.count("roi"), 1u);
  EXPECT_EQ(m.initializers.at("roi").dims, (std::vector<std::int64_t>{0}));
  EXPECT_EQ(m.initializers.at("roi").elementCount(), 0);
  EXPECT_TRUE(m.initializers.at("roi").floats.empty());
  // A zero-element tensor with raw bytes is still a size mismatch.
  const std::string bad = packedInts(1, {0}) + intField(2, kFloat) + bytesField(8, "roi") + bytesField(9, "abcd");
  EXPECT_THROW(parseModel(model(bytesField(5, bad))), FormatError);
}

TEST(OnnxReader, RejectsMalformedBytes) {
  EXPECT_THROW(parseModel("not a network"), FormatError);
  EXPECT_THROW(parseModel(""), FormatError);  // no graph
  const std::string good = model(smallGraph("Relu"));
  for (std::size_t cut : {std::size_t(1), good.size() / 3, good.size() / 2, good.size() - 1})
    EXPECT_THROW(parseModel(good.substr(0, cut)), FormatError) << "cut at " << cut;
  // A length prefix that runs past the end.
  EXPECT_THROW(parseModel(intField(1, 7) + key(7, 2) + varint(1000) + "abc"), FormatError);
  // A float tensor whose data does not match its dims.
  const std::string bad_tensor = packedInts(1, {4}) + intField(2, kFloat) + packedFloats(4, {1, 2}) + bytesField(8, "t");
  EXPECT_THROW(parseModel(model(bytesField(5, bad_tensor))), FormatError);
  EXPECT_THROW(readModel("/nonexistent/desslam/model.onnx"), FormatError);
}

TEST(OnnxReader, ReadsTheSharedDeepLabModel) {
  const auto file = test::sharedDir() / "models" / kDeepLabModelFile;
  DESSLAM_REQUIRE_SHARED(file);
  const Model m = readModel(file);
  EXPECT_EQ(m.opset, 11);
  ASSERT_EQ(m.inputs.size(), 1u);
  EXPECT_EQ(m.inputs[0].dims, (std::vector<std::int64_t>{1, 3, 257, 257}));
  ASSERT_EQ(m.outputs.size(), 1u);
  EXPECT_EQ(m.outputs[0].dims, (std::vector<std::int64_t>{1, 21, 257, 257}));
  int convs = 0, resizes = 0;
  for (const Node& n : m.nodes) {
    convs += n.op_type == "Conv";
    if (n.op_type == "Resize") {
      ++resizes;
      EXPECT_EQ(n.stringAttribute("coordinate_transformation_mode", ""), "align_corners");
    }
  }
  EXPECT_GT(convs, 50);
  EXPECT_EQ(resizes, 3);
}

TEST(OnnxReader, XnnpackBackendNamesAnUnsupportedOp) {
  if (!haveXnnpackBackend()) GTEST_SKIP() << "this build has no XNNPACK backend";
  test::TempDir dir;
  const auto file = dir.path() / "softmax.onnx";
  const std::string bytes = model(smallGraph("Softmax"));
  std::ofstream(file, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
  SemanticOptions options;
  options.backend = SegmentationBackend::kXnnpack;
  options.model_path = file.string();
  options.model_sha256.clear();
  try {
    makeSegmenter(options);
    FAIL() << "a Softmax model was accepted";
  } catch (const ConfigError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(file.string()), std::string::npos) << message;
    EXPECT_NE(message.find("Softmax"), std::string::npos) << message;
    EXPECT_NE(message.find("semantic.backend = opencv"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace desslam::semantic::onnx
