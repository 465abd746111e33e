// The XNNPACK network op by op against OpenCV dnn (the reference backend) on small hand-written
// ONNX graphs: Conv pads / strides / dilations / groups / depthwise multipliers, Clip, Relu, Add,
// GlobalAveragePool, Resize in each coordinate transformation mode, and DeepLab's
// image-pooling pattern (Resize of a 1x1 map, Concat, 1x1 Conv).
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include "onnx_test_encoder.hpp"
#include "semantic/onnx_reader.hpp"
#include "semantic/segmenter.hpp"
#if DESSLAM_HAVE_XNNPACK
#include "semantic/xnnpack_network.hpp"
#endif

namespace desslam::semantic {
namespace {

using namespace test::onnx_encoder;

std::vector<float> pseudoRandom(std::size_t n, unsigned seed) {
  std::vector<float> out(n);
  std::uint32_t s = 2463534242u ^ seed;
  for (auto& v : out) {
    s ^= s << 13;
    s ^= s >> 17;
    s ^= s << 5;
    v = float(s % 2001) / 1000.0f - 1.0f;  // [-1, 1]
  }
  return out;
}

std::int64_t product(const std::vector<std::int64_t>& dims) {
  std::int64_t n = 1;
  for (auto d : dims) n *= d;
  return n;
}

// A graph under construction: nodes and initializers, input "x".
struct GraphText {
  std::string nodes, initializers;
  unsigned seed = 1;
  std::string weights(const std::string& name, const std::vector<std::int64_t>& dims) {
    initializers += initializer(floatTensor(name, dims, pseudoRandom(std::size_t(product(dims)), seed++)));
    return name;
  }
};

// Runs the model through OpenCV dnn and through XnnpackNetwork on the same pseudo-random input;
// returns the largest absolute difference (and checks the output shapes agree).
double maxDifference(const std::string& model_bytes, const std::vector<std::int64_t>& input_nchw) {
#if DESSLAM_HAVE_XNNPACK
  const std::vector<float> input = pseudoRandom(std::size_t(product(input_nchw)), 99);
  cv::dnn::Net net = cv::dnn::readNetFromONNX(model_bytes.data(), model_bytes.size());
  const std::vector<int> blob_dims(input_nchw.begin(), input_nchw.end());
  cv::Mat blob(int(blob_dims.size()), blob_dims.data(), CV_32F, const_cast<float*>(input.data()));
  net.setInput(blob);
  const cv::Mat reference = net.forward().clone();

  XnnpackNetwork network(onnx::parseModel(model_bytes), 1);
  const auto in = network.inputShape();
  const std::size_t C = std::size_t(input_nchw[1]), H = std::size_t(input_nchw[2]), W = std::size_t(input_nchw[3]);
  EXPECT_EQ(in[1], H);
  EXPECT_EQ(in[2], W);
  EXPECT_EQ(in[3], C);
  for (std::size_t c = 0; c < C; ++c)
    for (std::size_t y = 0; y < H; ++y)
      for (std::size_t x = 0; x < W; ++x) network.input()[(y * W + x) * C + c] = input[(c * H + y) * W + x];
  const float* output = network.run();
  const auto out = network.outputShape();
  EXPECT_EQ(reference.dims, 4);
  if (reference.dims != 4) return INFINITY;
  EXPECT_EQ(std::size_t(reference.size[1]), out[3]);
  EXPECT_EQ(std::size_t(reference.size[2]), out[1]);
  EXPECT_EQ(std::size_t(reference.size[3]), out[2]);
  if (std::size_t(reference.size[1]) != out[3] || std::size_t(reference.size[2]) != out[1] ||
      std::size_t(reference.size[3]) != out[2])
    return INFINITY;
  double worst = 0;
  const float* ref = reference.ptr<float>();
  for (std::size_t c = 0; c < out[3]; ++c)
    for (std::size_t y = 0; y < out[1]; ++y)
      for (std::size_t x = 0; x < out[2]; ++x)
        worst = std::max(worst, std::abs(double(ref[(c * out[1] + y) * out[2] + x]) -
                                         double(output[(y * out[2] + x) * out[3] + c])));
  return worst;
#else
  return 0;
#endif
}

#define REQUIRE_XNNPACK()                                                      \
  do {                                                                         \
    if (!haveXnnpackBackend()) GTEST_SKIP() << "this build has no XNNPACK backend"; \
  } while (0)

std::string convModel(std::int64_t in_c, std::int64_t out_c, std::int64_t k, std::int64_t group,
                      std::vector<std::int64_t> pads, std::vector<std::int64_t> strides,
                      std::vector<std::int64_t> dilations, const std::vector<std::int64_t>& input) {
  GraphText g;
  const std::string w = g.weights("w", {out_c, in_c / group, k, k});
  const std::string b = g.weights("b", {out_c});
  g.nodes += node("Conv", {"x", w, b}, {"y"},
                  {intsAttr("kernel_shape", {k, k}), intsAttr("pads", pads), intsAttr("strides", strides),
                   intsAttr("dilations", dilations), intAttr("group", group)});
  return model(g.nodes + g.initializers + graphInput("x", input) + graphOutput("y", {}));
}

TEST(XnnpackNetwork, ConvolutionsMatchOpenCv) {
  REQUIRE_XNNPACK();
  const std::vector<std::int64_t> input{1, 6, 13, 11};
  struct Case { const char* what; std::int64_t out_c, k, group; std::vector<std::int64_t> pads, strides, dilations; };
  const std::vector<Case> cases = {
      {"3x3 stride 2, pads h1 w2", 8, 3, 1, {1, 2, 1, 2}, {2, 2}, {1, 1}},
      {"3x3 strides 2x1, dilations 1x2", 5, 3, 1, {1, 2, 1, 2}, {2, 1}, {1, 2}},
      {"1x1", 7, 1, 1, {0, 0, 0, 0}, {1, 1}, {1, 1}},
      {"grouped (2 groups) 3x3", 4, 3, 2, {1, 1, 1, 1}, {1, 1}, {1, 1}},
      {"depthwise 3x3 dilation 2", 6, 3, 6, {2, 2, 2, 2}, {1, 1}, {2, 2}},
      {"depthwise 3x3 stride 2", 6, 3, 6, {1, 1, 1, 1}, {2, 2}, {1, 1}},
      {"depthwise multiplier 2, dilation 4", 12, 3, 6, {4, 4, 4, 4}, {1, 1}, {4, 4}},
      {"5x5 unpadded", 3, 5, 1, {0, 0, 0, 0}, {1, 1}, {1, 1}},
  };
  for (const Case& c : cases)
    EXPECT_LT(maxDifference(convModel(6, c.out_c, c.k, c.group, c.pads, c.strides, c.dilations, input), input), 1e-4)
        << c.what;
}

TEST(XnnpackNetwork, ClipReluAddAndGlobalAveragePoolMatchOpenCv) {
  REQUIRE_XNNPACK();
  const std::vector<std::int64_t> input{1, 4, 9, 7};
  GraphText g;
  g.nodes += node("Conv", {"x", g.weights("w1", {4, 4, 1, 1}), g.weights("b1", {4})}, {"c1"},
                  {intsAttr("kernel_shape", {1, 1})});
  g.nodes += node("Clip", {"c1"}, {"r6"}, {floatAttr("min", 0.0f), floatAttr("max", 6.0f)});
  g.nodes += node("Add", {"r6", "x"}, {"sum"});
  g.nodes += node("Relu", {"sum"}, {"relu"});
  g.nodes += node("GlobalAveragePool", {"relu"}, {"pool"});
  g.nodes += node("Add", {"relu", "pool"}, {"y"});  // broadcast over H x W
  const std::string m = model(g.nodes + g.initializers + graphInput("x", input) + graphOutput("y", {}));
  EXPECT_LT(maxDifference(m, input), 1e-5);
}

std::string resizeModel(const std::string& transform, const std::vector<std::int64_t>& input,
                        const std::vector<float>& scales, const std::vector<std::int64_t>& sizes) {
  std::string init = initializer(floatTensor("roi", {0}, {}));
  std::vector<std::string> inputs{"x", "roi"};
  if (!scales.empty()) {
    init += initializer(floatTensor("scales", {4}, scales));
    inputs.push_back("scales");
  } else {
    init += initializer(floatTensor("scales", {0}, {}));
    init += initializer(int64Tensor("sizes", {4}, sizes));
    inputs.push_back("scales");
    inputs.push_back("sizes");
  }
  const std::string n = node("Resize", inputs, {"y"},
                             {stringAttr("mode", "linear"), stringAttr("coordinate_transformation_mode", transform)});
  return model(n + init + graphInput("x", input) + graphOutput("y", {}));
}

TEST(XnnpackNetwork, ResizeMatchesOpenCvInEachCoordinateMode) {
  REQUIRE_XNNPACK();
  const std::vector<std::int64_t> input{1, 3, 5, 7};
  for (const char* transform : {"align_corners", "half_pixel", "pytorch_half_pixel", "asymmetric"}) {
    EXPECT_LT(maxDifference(resizeModel(transform, input, {}, {1, 3, 13, 17}), input), 1e-5)
        << transform << " by sizes";
    EXPECT_LT(maxDifference(resizeModel(transform, input, {1, 1, 2, 2}, {}), input), 1e-5)
        << transform << " by scales";
  }
  // DeepLab's 33 -> 257 logits resize, one channel.
  const std::vector<std::int64_t> logits{1, 1, 33, 33};
  EXPECT_LT(maxDifference(resizeModel("align_corners", logits, {}, {1, 1, 257, 257}), logits), 1e-5);
}

TEST(XnnpackNetwork, ImagePoolingConcatAndProjectionMatchOpenCv) {
  REQUIRE_XNNPACK();
  // DeepLab's ASPP: [pool -> 1x1 conv -> relu -> resize to H x W] ++ [1x1 conv -> relu] -> 1x1 conv.
  const std::vector<std::int64_t> input{1, 8, 9, 9};
  GraphText g;
  g.nodes += node("GlobalAveragePool", {"x"}, {"pool"});
  g.nodes += node("Conv", {"pool", g.weights("wp", {5, 8, 1, 1}), g.weights("bp", {5})}, {"pc"},
                  {intsAttr("kernel_shape", {1, 1})});
  g.nodes += node("Relu", {"pc"}, {"pr"});
  g.initializers += initializer(floatTensor("roi", {0}, {})) + initializer(floatTensor("scales", {0}, {})) +
                    initializer(int64Tensor("sizes", {4}, {1, 5, 9, 9}));
  g.nodes += node("Resize", {"pr", "roi", "scales", "sizes"}, {"up"},
                  {stringAttr("mode", "linear"), stringAttr("coordinate_transformation_mode", "align_corners")});
  g.nodes += node("Conv", {"x", g.weights("wa", {6, 8, 1, 1}), g.weights("ba", {6})}, {"ac"},
                  {intsAttr("kernel_shape", {1, 1})});
  g.nodes += node("Relu", {"ac"}, {"ar"});
  g.nodes += node("Concat", {"up", "ar"}, {"cat"}, {intAttr("axis", 1)});
  g.nodes += node("Conv", {"cat", g.weights("wc", {4, 11, 1, 1}), g.weights("bc", {4})}, {"proj"},
                  {intsAttr("kernel_shape", {1, 1})});
  g.nodes += node("Relu", {"proj"}, {"y"});
  const std::string m = model(g.nodes + g.initializers + graphInput("x", input) + graphOutput("y", {}));
  EXPECT_LT(maxDifference(m, input), 1e-5);
}

#if DESSLAM_HAVE_XNNPACK
TEST(XnnpackNetwork, UnsupportedGraphsAreNamedErrors) {
  const std::vector<std::int64_t> input{1, 2, 4, 4};
  // A Concat that no 1x1 Conv consumes (XNNPACK of this version has no concatenation).
  const std::string concat = model(node("Concat", {"x", "x"}, {"y"}, {intAttr("axis", 1)}) + graphInput("x", input) +
                                   graphOutput("y", {}));
  try {
    XnnpackNetwork network(onnx::parseModel(concat), 1);
    FAIL() << "a bare Concat was accepted";
  } catch (const XnnpackError& e) {
    EXPECT_NE(std::string(e.what()).find("Concat"), std::string::npos) << e.what();
  }
  // Nearest-neighbour Resize.
  std::string init = initializer(floatTensor("roi", {0}, {})) + initializer(floatTensor("scales", {4}, {1, 1, 2, 2}));
  const std::string nearest = model(node("Resize", {"x", "roi", "scales"}, {"y"}, {stringAttr("mode", "nearest")}) +
                                    init + graphInput("x", input) + graphOutput("y", {}));
  try {
    XnnpackNetwork network(onnx::parseModel(nearest), 1);
    FAIL() << "a nearest Resize was accepted";
  } catch (const XnnpackError& e) {
    EXPECT_NE(std::string(e.what()).find("nearest"), std::string::npos) << e.what();
  }
}
#endif

}  // namespace
}  // namespace desslam::semantic
