#include "semantic/segmenter.hpp"

#include "core/error.hpp"
#include "semantic/deeplab_segmenter.hpp"
#include "semantic/mask_directory_segmenter.hpp"

namespace desslam::semantic {

std::unique_ptr<Segmenter> makeSegmenter(const SemanticOptions& options) {
  if (options.segmenter == "none") return nullptr;
  if (options.segmenter == "deeplab") return std::make_unique<DeepLabSegmenter>(options);
  if (options.segmenter == "mask_dir")
    return std::make_unique<MaskDirectorySegmenter>(options.mask_dir);
  throw ConfigError("config key semantic.segmenter: '" + options.segmenter +
                    "' is not one of deeplab, mask_dir, none");
}

}  // namespace desslam::semantic
