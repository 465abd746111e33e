// An ONNX graph (onnx_reader.hpp) rebuilt as an XNNPACK subgraph and runtime: fp32, NHWC, one
// input and one output. The semantic XNNPACK backend (xnnpack_deeplab_segmenter.hpp) runs the
// DeepLab model through it.
//
// Supported ONNX ops (what DeepLabV3-MobileNetV2 uses, plus a few trivial ones): Conv (any
// group, pads, strides, dilations; depthwise ones on XNNPACK's depthwise kernels), Clip (bounds
// as attributes or constant inputs), Relu, Add (numpy broadcasting), GlobalAveragePool, Resize
// (mode linear with sizes or scales; coordinate_transformation_mode align_corners, half_pixel,
// pytorch_half_pixel or asymmetric), Concat along channels when a 1x1 Conv consumes it,
// Constant, Identity, Dropout. XNNPACK 0.0~git20220216 (Debian bookworm) has no concatenation
// node, so such a Conv is split over the concatenated parts and the partial results added; a
// bilinear Resize of a 1x1 map (DeepLab's image pooling) is kept as a broadcast, not computed.
// Anything else throws XnnpackError naming the node.
#pragma once

#include <array>
#include <cstddef>
#include <memory>
#include <stdexcept>

#include "semantic/onnx_reader.hpp"

namespace desslam::semantic {

class XnnpackError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class XnnpackNetwork {
 public:
  using Shape = std::array<std::size_t, 4>;  // N, H, W, C

  // Builds the runtime (XNNPACK repacks the weights; `model` may be dropped afterwards).
  // threads <= 1: inference on the calling thread; else a pthreadpool of that many threads.
  // Throws XnnpackError for unsupported graphs or XNNPACK failures.
  XnnpackNetwork(const onnx::Model& model, int threads);
  ~XnnpackNetwork();
  XnnpackNetwork(const XnnpackNetwork&) = delete;
  XnnpackNetwork& operator=(const XnnpackNetwork&) = delete;

  const Shape& inputShape() const;   // the ONNX input [N, C, H, W] as NHWC
  const Shape& outputShape() const;  // the ONNX output as NHWC
  float* input();                    // write inputShape() elements here (NHWC) before run()
  const float* run();                // outputShape() elements (NHWC); valid until the next run()

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace desslam::semantic
