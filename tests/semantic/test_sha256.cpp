#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "semantic/sha256.hpp"
#include "support/temp_dir.hpp"

namespace desslam::semantic {
namespace {

// Known-answer vectors from FIPS 180-4's examples (NIST CSRC "SHA256.pdf").
TEST(Sha256, EmptyString) {
  EXPECT_EQ(sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
}

TEST(Sha256, Abc) {
  EXPECT_EQ(sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(Sha256, TwoBlockMessage) {
  // 56 bytes: the padding spills into a second block.
  EXPECT_EQ(sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

TEST(Sha256, MillionAsFedInOddChunks) {
  Sha256 hasher;
  const std::string chunk(997, 'a');  // prime length: chunks straddle block boundaries
  std::size_t fed = 0;
  while (fed < 1000000) {
    const std::size_t take = std::min<std::size_t>(chunk.size(), 1000000 - fed);
    hasher.update(chunk.data(), take);
    fed += take;
  }
  EXPECT_EQ(hasher.hexDigest(), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256, FileMatchesString) {
  test::TempDir dir;
  const auto file = dir.path() / "data.bin";
  std::string content;
  for (int i = 0; i < 200000; ++i) content.push_back(char(i * 7 % 256));
  std::ofstream(file, std::ios::binary) << content;
  EXPECT_EQ(sha256FileHex(file), sha256Hex(content));
}

TEST(Sha256, MissingFileThrowsNamingIt) {
  try {
    sha256FileHex("/nonexistent/desslam/model.onnx");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/desslam/model.onnx"), std::string::npos);
  }
}

}  // namespace
}  // namespace desslam::semantic
