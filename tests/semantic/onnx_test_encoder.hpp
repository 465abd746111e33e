// A minimal ONNX (protobuf wire format) encoder for tests: enough to write small models by hand
// for the ONNX reader and for comparing the XNNPACK network with OpenCV dnn op by op.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace desslam::test::onnx_encoder {

inline std::string varint(std::uint64_t v) {
  std::string out;
  do {
    std::uint8_t byte = v & 0x7f;
    v >>= 7;
    if (v) byte |= 0x80;
    out.push_back(char(byte));
  } while (v);
  return out;
}
inline std::string key(int field, int wire) { return varint(std::uint64_t(field) << 3 | std::uint64_t(wire)); }
inline std::string intField(int field, std::int64_t v) { return key(field, 0) + varint(std::uint64_t(v)); }
inline std::string bytesField(int field, const std::string& bytes) {
  return key(field, 2) + varint(bytes.size()) + bytes;
}
inline std::string floatField(int field, float f) {
  char b[4];
  std::memcpy(b, &f, 4);
  return key(field, 5) + std::string(b, 4);
}
inline std::string packedInts(int field, const std::vector<std::int64_t>& values) {
  std::string body;
  for (auto v : values) body += varint(std::uint64_t(v));
  return bytesField(field, body);
}
inline std::string packedFloats(int field, const std::vector<float>& values) {
  std::string body(values.size() * 4, '\0');
  if (!values.empty()) std::memcpy(body.data(), values.data(), body.size());  // data() may be null
  return bytesField(field, body);
}

// TensorProto (float, as raw_data) and (int64, as int64_data).
inline std::string floatTensor(const std::string& name, const std::vector<std::int64_t>& dims,
                               const std::vector<float>& values) {
  std::string raw(values.size() * 4, '\0');
  if (!values.empty()) std::memcpy(raw.data(), values.data(), raw.size());  // data() may be null
  return packedInts(1, dims) + intField(2, 1) + bytesField(8, name) + bytesField(9, raw);
}
inline std::string int64Tensor(const std::string& name, const std::vector<std::int64_t>& dims,
                               const std::vector<std::int64_t>& values) {
  return packedInts(1, dims) + intField(2, 7) + packedInts(7, values) + bytesField(8, name);
}

// AttributeProto with its type (FLOAT 1, INT 2, STRING 3, INTS 7).
inline std::string intAttr(const std::string& name, std::int64_t v) {
  return bytesField(1, name) + intField(3, v) + intField(20, 2);
}
inline std::string floatAttr(const std::string& name, float v) {
  return bytesField(1, name) + floatField(2, v) + intField(20, 1);
}
inline std::string stringAttr(const std::string& name, const std::string& v) {
  return bytesField(1, name) + bytesField(4, v) + intField(20, 3);
}
inline std::string intsAttr(const std::string& name, const std::vector<std::int64_t>& v) {
  std::string out = bytesField(1, name);
  for (auto x : v) out += intField(8, x);
  return out + intField(20, 7);
}

// NodeProto: graph field 1.
inline std::string node(const std::string& op, const std::vector<std::string>& inputs,
                        const std::vector<std::string>& outputs, const std::vector<std::string>& attributes = {},
                        const std::string& name = "") {
  std::string out;
  for (const auto& i : inputs) out += bytesField(1, i);
  for (const auto& o : outputs) out += bytesField(2, o);
  out += bytesField(3, name.empty() ? op + "_" + outputs.at(0) : name) + bytesField(4, op);
  for (const auto& a : attributes) out += bytesField(5, a);
  return bytesField(1, out);
}

// ValueInfoProto of a float tensor.
inline std::string valueInfo(const std::string& name, const std::vector<std::int64_t>& dims) {
  std::string shape;
  for (auto d : dims) shape += bytesField(1, intField(1, d));
  const std::string tensor_type = intField(1, 1) + bytesField(2, shape);
  return bytesField(1, name) + bytesField(2, bytesField(1, tensor_type));
}
inline std::string graphInput(const std::string& name, const std::vector<std::int64_t>& dims) {
  return bytesField(11, valueInfo(name, dims));
}
inline std::string graphOutput(const std::string& name, const std::vector<std::int64_t>& dims) {
  return bytesField(12, valueInfo(name, dims));
}
inline std::string initializer(const std::string& tensor) { return bytesField(5, tensor); }

// ModelProto (IR 7, opset 11) around the graph's fields.
inline std::string model(const std::string& graph_fields) {
  return intField(1, 7) + bytesField(7, bytesField(2, "test") + graph_fields) +
         bytesField(8, bytesField(1, "") + intField(2, 11));
}

}  // namespace desslam::test::onnx_encoder
