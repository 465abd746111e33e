#include "semantic/segmenter.hpp"

#include "core/error.hpp"
#include "semantic/deeplab_segmenter.hpp"
#include "semantic/mask_directory_segmenter.hpp"
#if DESSLAM_HAVE_XNNPACK
#include "semantic/xnnpack_deeplab_segmenter.hpp"
#endif

namespace desslam::semantic {

bool haveXnnpackBackend() { return DESSLAM_HAVE_XNNPACK != 0; }

std::unique_ptr<Segmenter> makeSegmenter(const SemanticOptions& options) {
  if (options.segmenter == "none") return nullptr;
  if (options.segmenter == "deeplab") {
    if (options.backend == "opencv") return std::make_unique<DeepLabSegmenter>(options);
    if (options.backend == "xnnpack") {
#if DESSLAM_HAVE_XNNPACK
      return std::make_unique<XnnpackDeepLabSegmenter>(options);
#else
      throw ConfigError(
          "config key semantic.backend: xnnpack, but this build has no XNNPACK (install "
          "libxnnpack-dev and libpthreadpool-dev, as scripts/install-and-build.sh does, and "
          "rebuild), or use semantic.backend = opencv");
#endif
    }
    throw ConfigError("config key semantic.backend: '" + options.backend +
                      "' is not one of opencv, xnnpack");
  }
  if (options.segmenter == "mask_dir")
    return std::make_unique<MaskDirectorySegmenter>(options.mask_dir);
  throw ConfigError("config key semantic.segmenter: '" + options.segmenter +
                    "' is not one of deeplab, mask_dir, none");
}

}  // namespace desslam::semantic
