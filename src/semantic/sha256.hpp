// SHA-256, used to check that the segmentation model on disk is the expected one: OpenSSL's
// libcrypto (EVP interface, Debian libssl-dev) behind a small interface of the project's own.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace desslam::semantic {

// Incremental hasher: update() any number of times, then hexDigest() once.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void update(const void* data, std::size_t size);
  void update(std::string_view data) { update(data.data(), data.size()); }
  // Lower-case hex of the 32-byte digest. Finishes the hash; the object must not be updated after.
  std::string hexDigest();

 private:
  struct Context;  // OpenSSL's EVP_MD_CTX, kept out of this header
  std::unique_ptr<Context> context_;
};

std::string sha256Hex(std::string_view data);
// Throws InputError naming the file when it cannot be read.
std::string sha256FileHex(const std::filesystem::path& file);

}  // namespace desslam::semantic
