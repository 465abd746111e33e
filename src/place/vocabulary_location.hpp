// Where the bag-of-words vocabulary file is: the configured path, or the project's default
// vocab/desslam_orb_k10l5.bin looked for in the data folders.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "place/vocabulary.hpp"

namespace desslam::place {

inline constexpr const char* kDefaultVocabularyFile = "desslam_orb_k10l5.bin";

// configured non-empty: that path only. Empty: vocab/<kDefaultVocabularyFile> in the data folders
// (core/data_location.hpp: $DESSLAM_DATA_DIR, $DESSLAM_SOURCE_DIR, the installed share/desslam
// beside the library or program, and the source tree when run from the build tree).
// Returns the first regular file found, or an empty path; `tried` (optional) lists the paths looked at.
std::filesystem::path resolveVocabularyPath(const std::string& configured,
                                            std::vector<std::filesystem::path>* tried = nullptr);

// Resolves and loads; throws ConfigError naming relocalisation.vocabulary and the paths tried
// when no file is found, InputError (from Vocabulary::load) for a bad file.
std::shared_ptr<const Vocabulary> loadVocabulary(const std::string& configured);

}  // namespace desslam::place
