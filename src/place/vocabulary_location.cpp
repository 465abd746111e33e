#include "place/vocabulary_location.hpp"

#include <system_error>

#include "core/data_location.hpp"
#include "core/error.hpp"

namespace desslam::place {

namespace fs = std::filesystem;

fs::path resolveVocabularyPath(const std::string& configured, std::vector<fs::path>* tried) {
  if (!configured.empty()) {  // an explicit path is the only place looked at
    if (tried != nullptr) *tried = {fs::path(configured)};
    std::error_code ec;
    return fs::is_regular_file(configured, ec) ? fs::path(configured).lexically_normal() : fs::path();
  }
  return findDataFile(fs::path("vocab") / kDefaultVocabularyFile, dataDirectories(), tried);
}

std::shared_ptr<const Vocabulary> loadVocabulary(const std::string& configured) {
  std::vector<fs::path> tried;
  const fs::path path = resolveVocabularyPath(configured, &tried);
  if (path.empty()) {
    throw ConfigError("config key relocalisation.vocabulary: vocabulary file not found; looked at:" +
                      listPaths(tried) +
                      "\nSet relocalisation.vocabulary to a file made by `desslam vocab train`, or DESSLAM_DATA_DIR "
                      "to a folder holding vocab/" + std::string(kDefaultVocabularyFile) +
                      " (the installed share/desslam, or the source tree)");
  }
  return std::make_shared<const Vocabulary>(Vocabulary::load(path));
}

}  // namespace desslam::place
