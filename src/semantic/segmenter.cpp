#include "semantic/segmenter.hpp"

#include "core/error.hpp"
#include "semantic/deeplab_segmenter.hpp"
#include "semantic/mask_directory_segmenter.hpp"
#if DESSLAM_HAVE_XNNPACK
#include "semantic/xnnpack_deeplab_segmenter.hpp"
#endif

namespace desslam::semantic {

bool haveXnnpackBackend() { return DESSLAM_HAVE_XNNPACK != 0; }

namespace {

std::unique_ptr<Segmenter> makeDeepLab(const SemanticOptions& options) {
  switch (options.backend) {
    case SegmentationBackend::kOpenCv:
      return std::make_unique<DeepLabSegmenter>(options);
    case SegmentationBackend::kXnnpack:
#if DESSLAM_HAVE_XNNPACK
      return std::make_unique<XnnpackDeepLabSegmenter>(options);
#else
      throw ConfigError(
          "config key semantic.backend: xnnpack, but this build has no XNNPACK (install "
          "libxnnpack-dev and libpthreadpool-dev, as scripts/install-and-build.sh does, and "
          "rebuild), or use semantic.backend = opencv");
#endif
  }
  throw ConfigError("config key semantic.backend: not one of opencv, xnnpack");  // a value outside the enum
}

}  // namespace

std::unique_ptr<Segmenter> makeSegmenter(const SemanticOptions& options) {
  switch (options.segmenter) {
    case SegmenterKind::kNone:
      return nullptr;
    case SegmenterKind::kDeepLab:
      return makeDeepLab(options);
    case SegmenterKind::kMaskDir:
      return std::make_unique<MaskDirectorySegmenter>(options.mask_dir);
  }
  throw ConfigError("config key semantic.segmenter: not one of deeplab, mask_dir, none");  // a value outside the enum
}

}  // namespace desslam::semantic
