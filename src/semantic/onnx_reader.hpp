// A small reader for ONNX model files (protobuf wire format, read directly; no libonnx or
// libprotobuf needed). It keeps what an inference backend needs: the graph's nodes in file
// order (ONNX requires topological order), their attributes, the initializers (weights) as
// float or int64 data, and the graph's inputs and outputs with their static shapes.
// Fields it does not use (doc strings, metadata, training info...) are skipped.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace desslam::semantic::onnx {

// Thrown for files that are not well-formed ONNX (truncated, bad wire types, bad sizes...).
class FormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// onnx.TensorProto.DataType values used here.
enum DataType : int { kFloat = 1, kInt32 = 6, kInt64 = 7 };

struct Tensor {
  std::string name;
  int data_type = 0;
  std::vector<std::int64_t> dims;
  std::vector<float> floats;        // data_type kFloat
  std::vector<std::int64_t> ints;   // data_type kInt32 or kInt64 (widened)
  std::int64_t elementCount() const;
};

struct Attribute {
  std::string name;
  float f = 0;
  std::int64_t i = 0;
  std::string s;
  std::vector<float> floats;
  std::vector<std::int64_t> ints;
  std::shared_ptr<Tensor> t;  // for Constant nodes
};

struct Node {
  std::string name, op_type, domain;
  std::vector<std::string> inputs, outputs;  // an empty input name means "not given"
  std::vector<Attribute> attributes;

  const Attribute* attribute(const std::string& attribute_name) const;  // nullptr if absent
  std::int64_t intAttribute(const std::string& attribute_name, std::int64_t fallback) const;
  float floatAttribute(const std::string& attribute_name, float fallback) const;
  std::string stringAttribute(const std::string& attribute_name, const std::string& fallback) const;
  std::vector<std::int64_t> intsAttribute(const std::string& attribute_name,
                                          std::vector<std::int64_t> fallback) const;
};

struct ValueInfo {
  std::string name;
  int elem_type = 0;
  std::vector<std::int64_t> dims;  // -1 for a symbolic or unknown dimension
};

struct Model {
  std::int64_t ir_version = 0;
  std::int64_t opset = 0;  // of the default ("" or "ai.onnx") domain
  std::vector<Node> nodes;
  std::map<std::string, Tensor> initializers;
  std::vector<ValueInfo> inputs;   // graph inputs that are not initializers
  std::vector<ValueInfo> outputs;
};

// Parses a serialized ModelProto. Throws FormatError when the bytes are not a well-formed
// ONNX model with a graph.
Model parseModel(const std::string& bytes);

// Reads and parses a file. Throws FormatError (also when the file cannot be read).
Model readModel(const std::filesystem::path& file);

}  // namespace desslam::semantic::onnx
