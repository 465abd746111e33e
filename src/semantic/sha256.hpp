// SHA-256 (FIPS 180-4), used to check that the segmentation model on disk is the expected one.
// Small and dependency-free on purpose: the project links no crypto library.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace desslam::semantic {

// Incremental hasher: update() any number of times, then hexDigest() once.
class Sha256 {
 public:
  Sha256();
  void update(const void* data, std::size_t size);
  void update(std::string_view data) { update(data.data(), data.size()); }
  // Lower-case hex of the 32-byte digest. Finishes the hash; the object must not be updated after.
  std::string hexDigest();

 private:
  void processBlock(const std::uint8_t* block);

  std::array<std::uint32_t, 8> state_;
  std::array<std::uint8_t, 64> buffer_{};
  std::size_t buffered_ = 0;
  std::uint64_t total_bytes_ = 0;
};

std::string sha256Hex(std::string_view data);
// Throws InputError naming the file when it cannot be read.
std::string sha256FileHex(const std::filesystem::path& file);

}  // namespace desslam::semantic
