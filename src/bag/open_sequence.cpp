#include "bag/open_sequence.hpp"

#include <algorithm>
#include <cctype>
#include <string>

#include "bag/bag_sequence.hpp"
#include "io/tum_dataset.hpp"

namespace desslam::bag {

bool isBagPath(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return false;
  if (std::filesystem::exists(path, ec)) return true;
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension == ".bag";
}

std::unique_ptr<io::RgbdSequence> openSequence(const std::filesystem::path& path, const BagOptions& topics) {
  if (isBagPath(path)) return std::make_unique<BagSequence>(BagSequence::open(path, topics));
  return std::make_unique<io::TumSequence>(io::TumSequence::open(path));
}

}  // namespace desslam::bag
