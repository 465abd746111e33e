#include "semantic/xnnpack_network.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <map>
#include <mutex>
#include <vector>

#include <pthreadpool.h>
#include <xnnpack.h>

namespace desslam::semantic {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr std::uint32_t kInputId = 0;   // external value ids
constexpr std::uint32_t kOutputId = 1;

using Shape = std::array<std::size_t, 4>;  // NHWC

std::string statusName(xnn_status s) {
  switch (s) {
    case xnn_status_success: return "success";
    case xnn_status_uninitialized: return "uninitialized";
    case xnn_status_invalid_parameter: return "invalid parameter";
    case xnn_status_invalid_state: return "invalid state";
    case xnn_status_unsupported_parameter: return "unsupported parameter";
    case xnn_status_unsupported_hardware: return "unsupported hardware";
    case xnn_status_out_of_memory: return "out of memory";
  }
  return "status " + std::to_string(int(s));
}


void check(xnn_status s, const std::string& what) {
  if (s != xnn_status_success) throw XnnpackError("XNNPACK " + what + " failed: " + statusName(s));
}

// A graph value as the builder knows it. Most are one XNNPACK tensor. Two are kept lazy
// because XNNPACK (this version) has no node for them, or they are cheaper that way:
//  - broadcast: `id` is [N, 1, 1, C] and the value is that spread over shape's H x W (the
//    bilinear Resize of a 1x1 map); elementwise ops and Add keep it lazy;
//  - concat: the value is `parts` concatenated along channels; only a 1x1 Conv may read it.
struct Value {
  std::uint32_t id = XNN_INVALID_VALUE_ID;
  Shape shape{};
  bool broadcast = false;
  std::vector<std::string> parts;
};

class GraphBuilder {
 public:
  GraphBuilder(const onnx::Model& model, xnn_subgraph_t subgraph, std::deque<std::vector<float>>& weights)
      : model_(model), subgraph_(subgraph), weights_(weights) {}

  // Defines the whole graph; returns the input and output shapes (NHWC).
  std::pair<Shape, Shape> build() {
    if (model_.inputs.size() != 1 || model_.outputs.size() != 1)
      throw XnnpackError("expected one graph input and one output, found " +
                       std::to_string(model_.inputs.size()) + " and " + std::to_string(model_.outputs.size()));
    const onnx::ValueInfo& in = model_.inputs[0];
    if (in.dims.size() != 4 || in.dims[1] <= 0 || in.dims[2] <= 0 || in.dims[3] <= 0)
      throw XnnpackError("graph input '" + in.name + "' is not a static NCHW 4-D tensor");
    output_name_ = model_.outputs[0].name;
    Value input;
    input.shape = {1, std::size_t(in.dims[2]), std::size_t(in.dims[3]), std::size_t(in.dims[1])};
    check(xnn_define_tensor_value(subgraph_, xnn_datatype_fp32, 4, input.shape.data(), nullptr, kInputId,
                                  XNN_VALUE_FLAG_EXTERNAL_INPUT, &input.id),
          "input tensor");
    values_[in.name] = input;

    for (const onnx::Node& node : model_.nodes) {
      try {
        defineNode(node);
      } catch (const XnnpackError& e) {
        throw XnnpackError("node '" + node.name + "' (" + node.op_type + "): " + e.what());
      }
    }

    auto it = values_.find(output_name_);
    if (it == values_.end()) throw XnnpackError("graph output '" + output_name_ + "' is never computed");
    Value out = it->second;
    if (!out.parts.empty()) throw XnnpackError("graph output is a Concat, which this backend cannot produce");
    if (out.broadcast) out = materialize(out);
    if (out.id != kOutputId) {  // an alias of another value: copy it out (clamp to +-inf)
      std::uint32_t id;
      defineTensor(out.shape, output_name_, &id);
      check(xnn_define_clamp(subgraph_, -kInf, kInf, out.id, id, 0), "output copy");
      out.id = id;
    }
    return {input.shape, out.shape};
  }

 private:
  // Internal tensor, or the external output when `name` is the graph output.
  void defineTensor(const Shape& shape, const std::string& name, std::uint32_t* id) {
    const bool is_output = name == output_name_;
    check(xnn_define_tensor_value(subgraph_, xnn_datatype_fp32, 4, shape.data(), nullptr,
                                  is_output ? kOutputId : XNN_INVALID_VALUE_ID,
                                  is_output ? XNN_VALUE_FLAG_EXTERNAL_OUTPUT : 0, id),
          "tensor");
  }

  std::uint32_t staticTensor(std::vector<std::size_t> dims, std::vector<float> data) {
    weights_.push_back(std::move(data));
    std::uint32_t id;
    check(xnn_define_tensor_value(subgraph_, xnn_datatype_fp32, dims.size(), dims.data(),
                                  weights_.back().data(), XNN_INVALID_VALUE_ID, 0, &id),
          "static tensor");
    return id;
  }

  const Value& value(const std::string& name) const {
    auto it = values_.find(name);
    if (it == values_.end()) throw XnnpackError("input '" + name + "' is not computed before use");
    return it->second;
  }

  const onnx::Tensor* constant(const std::string& name) const {
    if (name.empty()) return nullptr;
    if (auto it = model_.initializers.find(name); it != model_.initializers.end()) return &it->second;
    if (auto it = constants_.find(name); it != constants_.end()) return &it->second;
    return nullptr;
  }

  const onnx::Tensor& requireConstant(const onnx::Node& node, std::size_t input, const char* what) const {
    const onnx::Tensor* t = input < node.inputs.size() ? constant(node.inputs[input]) : nullptr;
    if (t == nullptr) throw XnnpackError(std::string(what) + " must be a constant (initializer)");
    return *t;
  }

  // A lazy broadcast becomes a real tensor (a bilinear resize of a 1x1 map is that value everywhere).
  Value materialize(const Value& v) {
    if (!v.parts.empty()) throw XnnpackError("a Concat may only feed a 1x1 Conv in this backend");
    if (!v.broadcast) return v;
    Value out;
    out.shape = v.shape;
    defineTensor(out.shape, "", &out.id);
    check(xnn_define_static_resize_bilinear_2d(subgraph_, v.shape[1], v.shape[2], v.id, out.id,
                                               XNN_FLAG_ALIGN_CORNERS),
          "broadcast resize");
    return out;
  }

  void defineNode(const onnx::Node& node) {
    if (!node.domain.empty() && node.domain != "ai.onnx")
      throw XnnpackError("op domain '" + node.domain + "' is not supported");
    if (node.outputs.empty()) throw XnnpackError("node has no output");
    const std::string& op = node.op_type;
    if (op == "Constant") return defineConstant(node);
    if (op == "Conv") return defineConv(node);
    if (op == "Clip" || op == "Relu") return defineClamp(node);
    if (op == "Add") return defineAdd(node);
    if (op == "GlobalAveragePool") return defineGlobalAveragePool(node);
    if (op == "Resize") return defineResize(node);
    if (op == "Concat") return defineConcat(node);
    if (op == "Identity" || op == "Dropout") {
      values_[node.outputs[0]] = value(node.inputs.at(0));
      return;
    }
    throw XnnpackError("op is not supported by the XNNPACK backend");
  }

  void defineConstant(const onnx::Node& node) {
    const onnx::Attribute* a = node.attribute("value");
    if (a == nullptr || !a->t) throw XnnpackError("Constant without a tensor 'value'");
    constants_[node.outputs[0]] = *a->t;
  }

  void defineConv(const onnx::Node& node) {
    if (node.inputs.size() < 2) throw XnnpackError("Conv needs input and weights");
    const onnx::Tensor& w = requireConstant(node, 1, "Conv weights");
    if (w.data_type != onnx::kFloat || w.dims.size() != 4)
      throw XnnpackError("Conv weights must be float [O, I/group, kH, kW]");
    const std::size_t out_channels = std::size_t(w.dims[0]), group_in = std::size_t(w.dims[1]);
    const std::size_t kh = std::size_t(w.dims[2]), kw = std::size_t(w.dims[3]);
    std::vector<float> bias(out_channels, 0.0f);
    if (node.inputs.size() > 2 && !node.inputs[2].empty()) {
      const onnx::Tensor& b = requireConstant(node, 2, "Conv bias");
      if (b.data_type != onnx::kFloat || b.floats.size() != out_channels)
        throw XnnpackError("Conv bias must be float [O]");
      bias = b.floats;
    }
    const std::string auto_pad = node.stringAttribute("auto_pad", "NOTSET");
    if (auto_pad != "NOTSET" && auto_pad != "VALID")
      throw XnnpackError("Conv auto_pad " + auto_pad + " is not supported");
    const auto pads = node.intsAttribute("pads", {0, 0, 0, 0});  // top, left, bottom, right
    const auto strides = node.intsAttribute("strides", {1, 1});
    const auto dilations = node.intsAttribute("dilations", {1, 1});
    const auto kernel = node.intsAttribute("kernel_shape", {std::int64_t(kh), std::int64_t(kw)});
    const std::int64_t group = node.intAttribute("group", 1);
    if (pads.size() != 4 || strides.size() != 2 || dilations.size() != 2 || kernel.size() != 2 || group < 1)
      throw XnnpackError("Conv attributes are not those of a 2-D convolution");
    if (kernel[0] != std::int64_t(kh) || kernel[1] != std::int64_t(kw))
      throw XnnpackError("Conv kernel_shape disagrees with the weights");
    for (auto v : pads) if (v < 0) throw XnnpackError("negative Conv pads");
    for (auto v : strides) if (v < 1) throw XnnpackError("Conv strides must be >= 1");
    for (auto v : dilations) if (v < 1) throw XnnpackError("Conv dilations must be >= 1");
    if (out_channels % std::size_t(group) != 0) throw XnnpackError("Conv output channels not divisible by group");

    const Value& x = value(node.inputs[0]);
    if (x.shape[3] != group_in * std::size_t(group))
      throw XnnpackError("Conv input has " + std::to_string(x.shape[3]) + " channels, weights expect " +
                       std::to_string(group_in * std::size_t(group)));

    // OIHW -> OHWI (XNNPACK's [O, kH, kW, I/group]); for a depthwise Conv (I/group = 1) the same
    // bytes are [1, kH, kW, O] after the transpose below.
    auto ohwi = [&](std::size_t in_begin, std::size_t in_count) {
      std::vector<float> out(out_channels * kh * kw * in_count);
      for (std::size_t o = 0; o < out_channels; ++o)
        for (std::size_t y = 0; y < kh; ++y)
          for (std::size_t xk = 0; xk < kw; ++xk)
            for (std::size_t i = 0; i < in_count; ++i)
              out[((o * kh + y) * kw + xk) * in_count + i] =
                  w.floats[((o * group_in + in_begin + i) * kh + y) * kw + xk];
      return out;
    };

    Value out;
    if (!x.parts.empty()) {
      // Concat -> 1x1 Conv: the sum over the parts of the Conv restricted to their channels.
      if (group != 1 || kh != 1 || kw != 1 || strides[0] != 1 || strides[1] != 1 ||
          pads[0] || pads[1] || pads[2] || pads[3])
        throw XnnpackError("a Concat may only feed a 1x1, stride-1, unpadded, ungrouped Conv in this backend");
      out.shape = {x.shape[0], x.shape[1], x.shape[2], out_channels};
      std::size_t offset = 0;
      std::uint32_t sum = XNN_INVALID_VALUE_ID;
      Shape sum_shape{};
      for (std::size_t p = 0; p < x.parts.size(); ++p) {
        const Value& part = value(x.parts[p]);
        const std::size_t c = part.shape[3];
        const Shape part_in = part.broadcast ? Shape{part.shape[0], 1, 1, c} : part.shape;
        const Shape part_out = {part_in[0], part_in[1], part_in[2], out_channels};
        const std::uint32_t filter = staticTensor({out_channels, 1, 1, c}, ohwi(offset, c));
        const std::uint32_t b = staticTensor({out_channels}, p == 0 ? bias : std::vector<float>(out_channels, 0.0f));
        std::uint32_t partial;
        defineTensor(part_out, "", &partial);
        check(xnn_define_convolution_2d(subgraph_, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, c, out_channels, -kInf,
                                        kInf, part.id, filter, b, partial, 0),
              "split 1x1 convolution");
        if (sum == XNN_INVALID_VALUE_ID) {
          sum = partial;
          sum_shape = part_out;
        } else {
          const Shape add_shape = {sum_shape[0], std::max(sum_shape[1], part_out[1]),
                                   std::max(sum_shape[2], part_out[2]), out_channels};
          const bool last = p + 1 == x.parts.size();
          std::uint32_t next;
          defineTensor(add_shape, last ? node.outputs[0] : "", &next);
          check(xnn_define_add2(subgraph_, -kInf, kInf, sum, partial, next, 0), "add of split convolutions");
          sum = next;
          sum_shape = add_shape;
        }
        offset += c;
      }
      if (sum_shape[1] != out.shape[1] || sum_shape[2] != out.shape[2])
        throw XnnpackError("every part of the Concat is a broadcast; not supported");
      out.id = sum;
      values_[node.outputs[0]] = out;
      return;
    }

    const Value in = materialize(x);
    const std::size_t eff_h = (kh - 1) * std::size_t(dilations[0]) + 1;
    const std::size_t eff_w = (kw - 1) * std::size_t(dilations[1]) + 1;
    std::size_t pt = std::size_t(pads[0]), pl = std::size_t(pads[1]), pb = std::size_t(pads[2]), pr = std::size_t(pads[3]);
    if (auto_pad == "VALID") pt = pl = pb = pr = 0;
    if (in.shape[1] + pt + pb < eff_h || in.shape[2] + pl + pr < eff_w)
      throw XnnpackError("Conv kernel larger than its padded input");
    out.shape = {in.shape[0], (in.shape[1] + pt + pb - eff_h) / std::size_t(strides[0]) + 1,
                 (in.shape[2] + pl + pr - eff_w) / std::size_t(strides[1]) + 1, out_channels};
    defineTensor(out.shape, node.outputs[0], &out.id);
    const std::uint32_t b = staticTensor({out_channels}, bias);
    if (group > 1 && group_in == 1 && std::size_t(group) == in.shape[3]) {
      // Depthwise: filter [1, kH, kW, O] with O = group * depth multiplier.
      const std::size_t multiplier = out_channels / std::size_t(group);
      std::vector<float> filter(kh * kw * out_channels);
      for (std::size_t o = 0; o < out_channels; ++o)
        for (std::size_t y = 0; y < kh; ++y)
          for (std::size_t xk = 0; xk < kw; ++xk)
            filter[(y * kw + xk) * out_channels + o] = w.floats[(o * kh + y) * kw + xk];
      const std::uint32_t f = staticTensor({1, kh, kw, out_channels}, std::move(filter));
      check(xnn_define_depthwise_convolution_2d(subgraph_, std::uint32_t(pt), std::uint32_t(pr), std::uint32_t(pb),
                                                std::uint32_t(pl), std::uint32_t(kh), std::uint32_t(kw),
                                                std::uint32_t(strides[0]), std::uint32_t(strides[1]),
                                                std::uint32_t(dilations[0]), std::uint32_t(dilations[1]),
                                                std::uint32_t(multiplier), in.shape[3], -kInf, kInf, in.id, f, b,
                                                out.id, 0),
            "depthwise convolution");
    } else {
      const std::uint32_t f = staticTensor({out_channels, kh, kw, group_in}, ohwi(0, group_in));
      check(xnn_define_convolution_2d(subgraph_, std::uint32_t(pt), std::uint32_t(pr), std::uint32_t(pb),
                                      std::uint32_t(pl), std::uint32_t(kh), std::uint32_t(kw),
                                      std::uint32_t(strides[0]), std::uint32_t(strides[1]),
                                      std::uint32_t(dilations[0]), std::uint32_t(dilations[1]),
                                      std::uint32_t(group), group_in, out_channels / std::size_t(group), -kInf, kInf,
                                      in.id, f, b, out.id, 0),
            "convolution");
    }
    values_[node.outputs[0]] = out;
  }

  // Clip (bounds as attributes before opset 11, as constant inputs since) and Relu.
  void defineClamp(const onnx::Node& node) {
    float lo = node.op_type == "Relu" ? 0.0f : -kInf, hi = kInf;
    if (node.op_type == "Clip") {
      lo = node.floatAttribute("min", lo);
      hi = node.floatAttribute("max", hi);
      auto bound = [&](std::size_t i, float& target) {
        if (i >= node.inputs.size() || node.inputs[i].empty()) return;
        const onnx::Tensor& t = requireConstant(node, i, "Clip bound");
        if (t.data_type != onnx::kFloat || t.floats.size() != 1) throw XnnpackError("Clip bound must be a float scalar");
        target = t.floats[0];
      };
      bound(1, lo);
      bound(2, hi);
    }
    const Value& x = value(node.inputs.at(0));
    if (!x.parts.empty()) throw XnnpackError("a Concat may only feed a 1x1 Conv in this backend");
    Value out = x;  // elementwise: a broadcast stays a broadcast of the clamped 1x1 map
    const Shape tensor_shape = x.broadcast ? Shape{x.shape[0], 1, 1, x.shape[3]} : x.shape;
    defineTensor(tensor_shape, x.broadcast ? "" : node.outputs[0], &out.id);
    check(xnn_define_clamp(subgraph_, lo, hi, x.id, out.id, 0), "clamp");
    values_[node.outputs[0]] = out;
  }

  void defineAdd(const onnx::Node& node) {
    if (node.inputs.size() != 2) throw XnnpackError("Add needs two inputs");
    if (constant(node.inputs[0]) || constant(node.inputs[1]))
      throw XnnpackError("Add of a constant is not supported");
    const Value& a = value(node.inputs[0]);
    const Value& b = value(node.inputs[1]);
    if (!a.parts.empty() || !b.parts.empty()) throw XnnpackError("a Concat may only feed a 1x1 Conv in this backend");
    auto tensorShape = [](const Value& v) { return v.broadcast ? Shape{v.shape[0], 1, 1, v.shape[3]} : v.shape; };
    const Shape sa = tensorShape(a), sb = tensorShape(b);
    Value out;
    for (int d = 0; d < 4; ++d) {
      if (sa[d] != sb[d] && sa[d] != 1 && sb[d] != 1) throw XnnpackError("Add shapes do not broadcast");
      out.shape[d] = std::max(sa[d], sb[d]);
    }
    out.broadcast = a.broadcast && b.broadcast;
    if (out.broadcast) out.shape = a.shape;
    const Shape t = out.broadcast ? Shape{out.shape[0], 1, 1, out.shape[3]} : out.shape;
    defineTensor(t, out.broadcast ? "" : node.outputs[0], &out.id);
    check(xnn_define_add2(subgraph_, -kInf, kInf, a.id, b.id, out.id, 0), "add");
    values_[node.outputs[0]] = out;
  }

  void defineGlobalAveragePool(const onnx::Node& node) {
    const Value x = materialize(value(node.inputs.at(0)));
    Value out;
    out.shape = {x.shape[0], 1, 1, x.shape[3]};
    defineTensor(out.shape, node.outputs[0], &out.id);
    check(xnn_define_global_average_pooling_2d(subgraph_, -kInf, kInf, x.id, out.id, 0), "global average pooling");
    values_[node.outputs[0]] = out;
  }

  void defineResize(const onnx::Node& node) {
    const std::string mode = node.stringAttribute("mode", "nearest");
    if (mode != "linear") throw XnnpackError("Resize mode '" + mode + "' is not supported (only linear)");
    const std::string transform = node.stringAttribute("coordinate_transformation_mode", "half_pixel");
    std::uint32_t flags = 0;
    if (transform == "align_corners") flags = XNN_FLAG_ALIGN_CORNERS;
    // pytorch_half_pixel is half_pixel except for an output length of 1 (checked below).
    else if (transform == "asymmetric") flags = XNN_FLAG_TENSORFLOW_LEGACY_MODE;
    else if (transform != "half_pixel" && transform != "pytorch_half_pixel")
      throw XnnpackError("Resize coordinate_transformation_mode '" + transform + "' is not supported");

    const Value& x = value(node.inputs.at(0));
    if (!x.parts.empty()) throw XnnpackError("a Concat may only feed a 1x1 Conv in this backend");
    // Output size: `sizes` (input 3, NCHW) or `scales` (input 2; opset 10 has scales as input 1).
    std::size_t out_h = 0, out_w = 0;
    const onnx::Tensor* sizes = node.inputs.size() > 3 ? constant(node.inputs[3]) : nullptr;
    const onnx::Tensor* scales = nullptr;
    if (node.inputs.size() > 2) scales = constant(node.inputs[2]);
    else if (node.inputs.size() == 2) scales = constant(node.inputs[1]);
    if (sizes != nullptr && sizes->ints.size() == 4) {
      if (sizes->ints[0] != std::int64_t(x.shape[0]) || sizes->ints[1] != std::int64_t(x.shape[3]))
        throw XnnpackError("Resize may only change height and width");
      out_h = std::size_t(sizes->ints[2]);
      out_w = std::size_t(sizes->ints[3]);
    } else if (scales != nullptr && scales->floats.size() == 4) {
      if (scales->floats[0] != 1.0f || scales->floats[1] != 1.0f)
        throw XnnpackError("Resize may only change height and width");
      out_h = std::size_t(std::floor(double(x.shape[1]) * scales->floats[2]));
      out_w = std::size_t(std::floor(double(x.shape[2]) * scales->floats[3]));
    } else {
      throw XnnpackError("Resize needs constant 4-element sizes or scales");
    }
    if (out_h == 0 || out_w == 0) throw XnnpackError("Resize to an empty size");
    if (transform == "pytorch_half_pixel" && (out_h == 1 || out_w == 1) && !(x.shape[1] == 1 && x.shape[2] == 1))
      throw XnnpackError("Resize pytorch_half_pixel to a length of 1 is not supported");

    Value out = x;
    out.shape[1] = out_h;
    out.shape[2] = out_w;
    const bool from_single_pixel = x.broadcast || (x.shape[1] == 1 && x.shape[2] == 1);
    if (from_single_pixel) {
      out.broadcast = true;  // every output pixel is the single input pixel: kept lazy
    } else if (out_h != x.shape[1] || out_w != x.shape[2]) {
      defineTensor(out.shape, node.outputs[0], &out.id);
      check(xnn_define_static_resize_bilinear_2d(subgraph_, out_h, out_w, x.id, out.id, flags),
            "bilinear resize");
    }  // else the same size: a bilinear resize to the same size is the identity, an alias
    values_[node.outputs[0]] = out;
  }

  void defineConcat(const onnx::Node& node) {
    const std::int64_t axis = node.intAttribute("axis", 1);
    if (axis != 1 && axis != -3) throw XnnpackError("Concat only along channels (axis 1) is supported");
    Value out;
    for (const std::string& name : node.inputs) {
      const Value& part = value(name);
      if (!part.parts.empty()) {
        out.parts.insert(out.parts.end(), part.parts.begin(), part.parts.end());
      } else {
        out.parts.push_back(name);
      }
      if (out.shape[0] == 0) {
        out.shape = part.shape;
        out.shape[3] = 0;
      } else if (part.shape[0] != out.shape[0] || part.shape[1] != out.shape[1] || part.shape[2] != out.shape[2]) {
        throw XnnpackError("Concat inputs differ in size");
      }
      out.shape[3] += part.shape[3];
    }
    values_[node.outputs[0]] = out;
  }

  const onnx::Model& model_;
  xnn_subgraph_t subgraph_;
  std::deque<std::vector<float>>& weights_;
  std::map<std::string, Value> values_;
  std::map<std::string, onnx::Tensor> constants_;
  std::string output_name_;
};

void initializeXnnpack() {
  static std::once_flag once;
  static xnn_status status = xnn_status_uninitialized;
  std::call_once(once, [] { status = xnn_initialize(nullptr); });  // process-wide, never undone
  if (status != xnn_status_success)
    throw XnnpackError("XNNPACK could not be initialized (" + statusName(status) + ")");
}

}  // namespace

struct XnnpackNetwork::Impl {
  std::deque<std::vector<float>> weights;  // static tensors; must outlive the runtime
  pthreadpool_t pool = nullptr;
  xnn_runtime_t runtime = nullptr;
  Shape input_shape{}, output_shape{};
  std::vector<float> input, output;  // external buffers (the input with XNNPACK's read-past padding)

  ~Impl() {
    if (runtime != nullptr) xnn_delete_runtime(runtime);
    if (pool != nullptr) pthreadpool_destroy(pool);
  }
};

XnnpackNetwork::XnnpackNetwork(const onnx::Model& model, int threads) : impl_(std::make_unique<Impl>()) {
  initializeXnnpack();
  xnn_subgraph_t subgraph = nullptr;
  check(xnn_create_subgraph(2, 0, &subgraph), "subgraph creation");
  try {
    GraphBuilder builder(model, subgraph, impl_->weights);
    std::tie(impl_->input_shape, impl_->output_shape) = builder.build();
    if (threads > 1) {
      impl_->pool = pthreadpool_create(std::size_t(threads));
      if (impl_->pool == nullptr) throw XnnpackError("pthreadpool_create failed");
    }
    // With a pool, its workers go back to the scheduler after each inference instead of spinning:
    // on 2 cores they would take CPU time from tracking between frames.
    check(xnn_create_runtime_v2(subgraph, impl_->pool, impl_->pool != nullptr ? XNN_FLAG_YIELD_WORKERS : 0,
                                &impl_->runtime),
          "runtime creation");
  } catch (...) {
    xnn_delete_subgraph(subgraph);
    throw;
  }
  xnn_delete_subgraph(subgraph);

  const Shape& in = impl_->input_shape;
  const Shape& out = impl_->output_shape;
  // XNNPACK may read (never use) up to XNN_EXTRA_BYTES past an input.
  impl_->input.assign(in[0] * in[1] * in[2] * in[3] + XNN_EXTRA_BYTES / sizeof(float), 0.0f);
  impl_->output.assign(out[0] * out[1] * out[2] * out[3], 0.0f);
  const std::array<xnn_external_value, 2> external = {xnn_external_value{kInputId, impl_->input.data()},
                                                      xnn_external_value{kOutputId, impl_->output.data()}};
  check(xnn_setup_runtime(impl_->runtime, external.size(), external.data()), "runtime setup");
}

XnnpackNetwork::~XnnpackNetwork() = default;

const XnnpackNetwork::Shape& XnnpackNetwork::inputShape() const { return impl_->input_shape; }
const XnnpackNetwork::Shape& XnnpackNetwork::outputShape() const { return impl_->output_shape; }
float* XnnpackNetwork::input() { return impl_->input.data(); }

const float* XnnpackNetwork::run() {
  check(xnn_invoke_runtime(impl_->runtime), "inference");
  return impl_->output.data();
}

}  // namespace desslam::semantic
