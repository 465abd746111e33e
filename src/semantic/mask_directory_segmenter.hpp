// Precomputed masks: one PNG per RGB frame with the same file name; nonzero = dynamic.
// Lets runs use masks from another network (or ground-truth masks) without the model.
#pragma once

#include <filesystem>
#include <string>

#include "semantic/segmenter.hpp"

namespace desslam::semantic {

class MaskDirectorySegmenter final : public Segmenter {
 public:
  // Throws InputError when `directory` does not exist.
  explicit MaskDirectorySegmenter(std::filesystem::path directory);

  // Reads <directory>/<frame_name>; any nonzero value in a colour channel is dynamic (alpha is
  // ignored). labels stays empty. Throws InputError naming the file when it is missing,
  // unreadable, or its size differs from the image's.
  Segmentation segment(const cv::Mat& bgr, const std::string& frame_name) override;
  std::string name() const override { return "mask_dir"; }

 private:
  std::filesystem::path directory_;
};

}  // namespace desslam::semantic
