#include "semantic/onnx_reader.hpp"

#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

namespace desslam::semantic::onnx {
namespace {

// Protobuf wire types.
enum WireType : int { kVarint = 0, kFixed64 = 1, kLengthDelimited = 2, kFixed32 = 5 };

// Bounds-checked cursor over one message's bytes.
class Reader {
 public:
  Reader(const char* begin, const char* end, const char* what) : p_(begin), end_(end), what_(what) {}

  bool atEnd() const { return p_ >= end_; }

  std::uint64_t varint() {
    std::uint64_t value = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      if (p_ >= end_) fail("truncated varint");
      const auto byte = static_cast<std::uint8_t>(*p_++);
      value |= std::uint64_t(byte & 0x7f) << shift;
      if ((byte & 0x80) == 0) return value;
    }
    fail("varint longer than 10 bytes");
  }

  // Reads a field key; returns false at the end of the message.
  bool next(int& field, int& wire) {
    if (atEnd()) return false;
    const std::uint64_t key = varint();
    field = int(key >> 3);
    wire = int(key & 7);
    if (field == 0) fail("field number 0");
    return true;
  }

  Reader sub() {
    const std::uint64_t size = varint();
    if (size > std::uint64_t(end_ - p_)) fail("length-delimited field runs past its message");
    Reader r(p_, p_ + size, what_);
    p_ += size;
    return r;
  }

  std::string bytes() {
    Reader r = sub();
    return std::string(r.p_, r.end_);
  }

  std::uint32_t fixed32() {
    if (end_ - p_ < 4) fail("truncated fixed32");
    std::uint32_t v;
    std::memcpy(&v, p_, 4);  // little-endian on the wire; this code assumes a little-endian host
    p_ += 4;
    return v;
  }

  std::uint64_t fixed64() {
    if (end_ - p_ < 8) fail("truncated fixed64");
    std::uint64_t v;
    std::memcpy(&v, p_, 8);
    p_ += 8;
    return v;
  }

  float float32() {
    const std::uint32_t bits = fixed32();
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
  }

  void skip(int wire) {
    switch (wire) {
      case kVarint: varint(); break;
      case kFixed64: fixed64(); break;
      case kLengthDelimited: sub(); break;
      case kFixed32: fixed32(); break;
      default: fail("unsupported wire type " + std::to_string(wire));
    }
  }

  void expect(int wire, int wanted, const char* field_name) {
    if (wire != wanted)
      fail(std::string("field ") + field_name + " has wire type " + std::to_string(wire));
  }

  // Repeated scalar fields may come packed (one length-delimited run) or one per key.
  void int64s(int wire, std::vector<std::int64_t>& out) {
    if (wire == kLengthDelimited) {
      Reader r = sub();
      while (!r.atEnd()) out.push_back(std::int64_t(r.varint()));
    } else {
      expect(wire, kVarint, "repeated int");
      out.push_back(std::int64_t(varint()));
    }
  }

  void floats(int wire, std::vector<float>& out) {
    if (wire == kLengthDelimited) {
      Reader r = sub();
      if ((r.end_ - r.p_) % 4 != 0) fail("packed float field size is not a multiple of 4");
      while (!r.atEnd()) out.push_back(r.float32());
    } else {
      expect(wire, kFixed32, "repeated float");
      out.push_back(float32());
    }
  }

  [[noreturn]] void fail(const std::string& message) const {
    throw FormatError(std::string("malformed ONNX ") + what_ + ": " + message);
  }

 private:
  const char* p_;
  const char* end_;
  const char* what_;
};

Tensor parseTensor(Reader r) {
  Tensor t;
  std::string raw;
  bool has_raw = false;
  std::vector<std::int64_t> int_data;
  int field, wire;
  while (r.next(field, wire)) {
    switch (field) {
      case 1: r.int64s(wire, t.dims); break;
      case 2: r.expect(wire, kVarint, "data_type"); t.data_type = int(r.varint()); break;
      case 4: r.floats(wire, t.floats); break;
      case 5:  // int32_data (varint-encoded)
      case 7:  // int64_data
        r.int64s(wire, int_data);
        break;
      case 8: r.expect(wire, kLengthDelimited, "name"); t.name = r.bytes(); break;
      case 9: r.expect(wire, kLengthDelimited, "raw_data"); raw = r.bytes(); has_raw = true; break;
      case 14:
        r.expect(wire, kVarint, "data_location");
        if (r.varint() != 0) r.fail("tensor uses external data, which is not supported");
        break;
      default: r.skip(wire);
    }
  }
  for (std::int64_t d : t.dims)
    if (d < 0) r.fail("tensor '" + t.name + "' has a negative dimension");
  const std::int64_t count = t.elementCount();
  if (count > (std::int64_t(1) << 31)) r.fail("tensor '" + t.name + "' is too large");
  if (t.data_type == kFloat) {
    if (has_raw) {
      if (std::int64_t(raw.size()) != count * 4) r.fail("tensor '" + t.name + "' raw_data size mismatch");
      t.floats.resize(std::size_t(count));
      // An empty tensor (a zero dimension; the shared DeepLab model has one) has no buffer:
      // data() may be null, and memcpy with a null pointer is undefined even for 0 bytes.
      if (count > 0) std::memcpy(t.floats.data(), raw.data(), raw.size());
    } else if (std::int64_t(t.floats.size()) != count) {
      r.fail("tensor '" + t.name + "' float_data has " + std::to_string(t.floats.size()) +
             " values for " + std::to_string(count) + " elements");
    }
  } else if (t.data_type == kInt64 || t.data_type == kInt32) {
    if (has_raw) {
      const std::size_t width = t.data_type == kInt64 ? 8 : 4;
      if (std::int64_t(raw.size()) != count * std::int64_t(width))
        r.fail("tensor '" + t.name + "' raw_data size mismatch");
      t.ints.resize(std::size_t(count));
      for (std::int64_t i = 0; i < count; ++i) {
        if (width == 8) {
          std::int64_t v;
          std::memcpy(&v, raw.data() + i * 8, 8);
          t.ints[std::size_t(i)] = v;
        } else {
          std::int32_t v;
          std::memcpy(&v, raw.data() + i * 4, 4);
          t.ints[std::size_t(i)] = v;
        }
      }
    } else {
      if (t.data_type == kInt32)
        for (auto& v : int_data) v = std::int32_t(std::uint32_t(std::uint64_t(v)));
      t.ints = std::move(int_data);
      if (std::int64_t(t.ints.size()) != count) r.fail("tensor '" + t.name + "' int data size mismatch");
    }
  }
  // Other data types are kept without data; a backend that needs them rejects the model.
  return t;
}

Attribute parseAttribute(Reader r) {
  Attribute a;
  int field, wire;
  while (r.next(field, wire)) {
    switch (field) {
      case 1: r.expect(wire, kLengthDelimited, "name"); a.name = r.bytes(); break;
      case 2: r.expect(wire, kFixed32, "f"); a.f = r.float32(); break;
      case 3: r.expect(wire, kVarint, "i"); a.i = std::int64_t(r.varint()); break;
      case 4: r.expect(wire, kLengthDelimited, "s"); a.s = r.bytes(); break;
      case 5:
        r.expect(wire, kLengthDelimited, "t");
        a.t = std::make_shared<Tensor>(parseTensor(r.sub()));
        break;
      case 7: r.floats(wire, a.floats); break;
      case 8: r.int64s(wire, a.ints); break;
      default: r.skip(wire);
    }
  }
  return a;
}

Node parseNode(Reader r) {
  Node n;
  int field, wire;
  while (r.next(field, wire)) {
    switch (field) {
      case 1: r.expect(wire, kLengthDelimited, "input"); n.inputs.push_back(r.bytes()); break;
      case 2: r.expect(wire, kLengthDelimited, "output"); n.outputs.push_back(r.bytes()); break;
      case 3: r.expect(wire, kLengthDelimited, "name"); n.name = r.bytes(); break;
      case 4: r.expect(wire, kLengthDelimited, "op_type"); n.op_type = r.bytes(); break;
      case 5: r.expect(wire, kLengthDelimited, "attribute"); n.attributes.push_back(parseAttribute(r.sub())); break;
      case 7: r.expect(wire, kLengthDelimited, "domain"); n.domain = r.bytes(); break;
      default: r.skip(wire);
    }
  }
  if (n.op_type.empty()) r.fail("node '" + n.name + "' has no op_type");
  return n;
}

// ValueInfoProto -> TypeProto -> TypeProto.Tensor -> TensorShapeProto -> Dimension.
ValueInfo parseValueInfo(Reader r) {
  ValueInfo v;
  int field, wire;
  while (r.next(field, wire)) {
    if (field == 1 && wire == kLengthDelimited) {
      v.name = r.bytes();
    } else if (field == 2 && wire == kLengthDelimited) {
      Reader type = r.sub();
      int tf, tw;
      while (type.next(tf, tw)) {
        if (tf != 1 || tw != kLengthDelimited) { type.skip(tw); continue; }
        Reader tensor = type.sub();
        int f, w;
        while (tensor.next(f, w)) {
          if (f == 1 && w == kVarint) {
            v.elem_type = int(tensor.varint());
          } else if (f == 2 && w == kLengthDelimited) {
            Reader shape = tensor.sub();
            int sf, sw;
            while (shape.next(sf, sw)) {
              if (sf != 1 || sw != kLengthDelimited) { shape.skip(sw); continue; }
              Reader dim = shape.sub();
              std::int64_t value = -1;
              int df, dw;
              while (dim.next(df, dw)) {
                if (df == 1 && dw == kVarint) value = std::int64_t(dim.varint());
                else dim.skip(dw);
              }
              v.dims.push_back(value);
            }
          } else {
            tensor.skip(w);
          }
        }
      }
    } else {
      r.skip(wire);
    }
  }
  return v;
}

void parseGraph(Reader r, Model& model) {
  std::vector<ValueInfo> inputs;
  int field, wire;
  while (r.next(field, wire)) {
    switch (field) {
      case 1: r.expect(wire, kLengthDelimited, "node"); model.nodes.push_back(parseNode(r.sub())); break;
      case 5: {
        r.expect(wire, kLengthDelimited, "initializer");
        Tensor t = parseTensor(r.sub());
        std::string name = t.name;
        model.initializers[name] = std::move(t);
        break;
      }
      case 11: r.expect(wire, kLengthDelimited, "input"); inputs.push_back(parseValueInfo(r.sub())); break;
      case 12: r.expect(wire, kLengthDelimited, "output"); model.outputs.push_back(parseValueInfo(r.sub())); break;
      default: r.skip(wire);
    }
  }
  // Before IR version 4 initializers were also listed as graph inputs.
  for (auto& v : inputs)
    if (model.initializers.count(v.name) == 0) model.inputs.push_back(std::move(v));
}

}  // namespace

std::int64_t Tensor::elementCount() const {
  std::int64_t n = 1;
  for (std::int64_t d : dims) {
    if (d != 0 && n > std::numeric_limits<std::int64_t>::max() / d) return std::numeric_limits<std::int64_t>::max();
    n *= d;
  }
  return n;
}

const Attribute* Node::attribute(const std::string& attribute_name) const {
  for (const auto& a : attributes)
    if (a.name == attribute_name) return &a;
  return nullptr;
}

std::int64_t Node::intAttribute(const std::string& attribute_name, std::int64_t fallback) const {
  const Attribute* a = attribute(attribute_name);
  return a ? a->i : fallback;
}

float Node::floatAttribute(const std::string& attribute_name, float fallback) const {
  const Attribute* a = attribute(attribute_name);
  return a ? a->f : fallback;
}

std::string Node::stringAttribute(const std::string& attribute_name, const std::string& fallback) const {
  const Attribute* a = attribute(attribute_name);
  return a ? a->s : fallback;
}

std::vector<std::int64_t> Node::intsAttribute(const std::string& attribute_name,
                                              std::vector<std::int64_t> fallback) const {
  const Attribute* a = attribute(attribute_name);
  return a ? a->ints : fallback;
}

Model parseModel(const std::string& bytes) {
  Model model;
  Reader r(bytes.data(), bytes.data() + bytes.size(), "model");
  bool has_graph = false;
  int field, wire;
  while (r.next(field, wire)) {
    switch (field) {
      case 1: r.expect(wire, kVarint, "ir_version"); model.ir_version = std::int64_t(r.varint()); break;
      case 7:
        r.expect(wire, kLengthDelimited, "graph");
        parseGraph(r.sub(), model);
        has_graph = true;
        break;
      case 8: {
        r.expect(wire, kLengthDelimited, "opset_import");
        Reader op = r.sub();
        std::string domain;
        std::int64_t version = 0;
        int f, w;
        while (op.next(f, w)) {
          if (f == 1 && w == kLengthDelimited) domain = op.bytes();
          else if (f == 2 && w == kVarint) version = std::int64_t(op.varint());
          else op.skip(w);
        }
        if (domain.empty() || domain == "ai.onnx") model.opset = version;
        break;
      }
      default: r.skip(wire);
    }
  }
  if (!has_graph || model.ir_version <= 0) r.fail("no ir_version or no graph (not an ONNX model?)");
  return model;
}

Model readModel(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw FormatError("cannot read " + file.string());
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (!in && !in.eof()) throw FormatError("cannot read " + file.string());
  return parseModel(buffer.str());
}

}  // namespace desslam::semantic::onnx
