#include "place/vocabulary_location.hpp"

#include <unistd.h>

#include <array>
#include <cstdlib>
#include <system_error>

#include "core/error.hpp"

namespace desslam::place {

namespace fs = std::filesystem;

namespace {
fs::path executableDir() {
  std::array<char, 4096> buffer{};
  const ssize_t n = ::readlink("/proc/self/exe", buffer.data(), buffer.size() - 1);
  if (n <= 0) return {};
  return fs::path(std::string(buffer.data(), static_cast<size_t>(n))).parent_path();
}
}  // namespace

fs::path resolveVocabularyPath(const std::string& configured, std::vector<fs::path>* tried) {
  std::vector<fs::path> candidates;
  if (!configured.empty()) {
    candidates.emplace_back(configured);  // an explicit path is the only place looked at
  } else {
    if (const char* env = std::getenv("DESSLAM_SOURCE_DIR"); env != nullptr && *env != '\0')
      candidates.push_back(fs::path(env) / "vocab" / kDefaultVocabularyFile);
    candidates.push_back(fs::path("vocab") / kDefaultVocabularyFile);
    if (const fs::path exe_dir = executableDir(); !exe_dir.empty()) {
      candidates.push_back(exe_dir / ".." / "vocab" / kDefaultVocabularyFile);        // build/desslam
      candidates.push_back(exe_dir / ".." / ".." / "vocab" / kDefaultVocabularyFile);  // build/tests/x
    }
#ifdef DESSLAM_VOCABULARY_DIR
    candidates.push_back(fs::path(DESSLAM_VOCABULARY_DIR) / kDefaultVocabularyFile);
#endif
  }
  if (tried != nullptr) *tried = candidates;
  for (const fs::path& candidate : candidates) {
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return candidate.lexically_normal();
  }
  return {};
}

std::shared_ptr<const Vocabulary> loadVocabulary(const std::string& configured) {
  std::vector<fs::path> tried;
  const fs::path path = resolveVocabularyPath(configured, &tried);
  if (path.empty()) {
    std::string list;
    for (const fs::path& p : tried) list += "\n  " + p.string();
    throw ConfigError("config key relocalisation.vocabulary: vocabulary file not found; looked at:" + list +
                      "\nSet relocalisation.vocabulary to a file made by `desslam vocab train`, or run from "
                      "the project folder (vocab/" + std::string(kDefaultVocabularyFile) + ")");
  }
  return std::make_shared<const Vocabulary>(Vocabulary::load(path));
}

}  // namespace desslam::place
