// Where the bag-of-words vocabulary file is: the configured path, or the project's default
// vocab/desslam_orb_k10l5.bin looked for in the usual places.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "place/vocabulary.hpp"

namespace desslam::place {

inline constexpr const char* kDefaultVocabularyFile = "desslam_orb_k10l5.bin";

// configured non-empty: that path only. Empty: $DESSLAM_SOURCE_DIR/vocab, ./vocab, <program
// dir>/../vocab, <program dir>/../../vocab, then the source tree this library was built from.
// Returns the first regular file found, or an empty path; `tried` (optional) lists the paths looked at.
std::filesystem::path resolveVocabularyPath(const std::string& configured,
                                            std::vector<std::filesystem::path>* tried = nullptr);

// Resolves and loads; throws ConfigError naming relocalisation.vocabulary and the paths tried
// when no file is found, InputError (from Vocabulary::load) for a bad file.
std::shared_ptr<const Vocabulary> loadVocabulary(const std::string& configured);

}  // namespace desslam::place
