// Keyframe database for relocalisation and loop detection: the bag-of-words vector of every
// keyframe (inverted file, loop/bow_database.hpp) and its direct index (feature indices per
// vocabulary node), kept up to date by local mapping (add on insertion, erase on culling) and
// queried by tracking with a lost frame's bag of words.
//
// Lock discipline: one internal mutex guards the id -> keyframe table; the inner BowDatabase has
// its own mutex, always taken after this one (never the reverse), so every method is safe to call
// from any thread. The database never takes the Map lock and reads only immutable keyframe fields
// (id, features, status), so callers may hold Map::mutex() or not. Results are copies. A keyframe
// returned by query() may have been culled since: check kf->bad under the Map lock (keyframes are
// never freed while the Map lives, so the pointer stays valid).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <vector>

#include "place/bow_database.hpp"
#include "place/bow_types.hpp"
#include "place/vocabulary.hpp"
#include "map/features.hpp"
#include "map/map_types.hpp"

namespace desslam::place {

// What the vocabulary makes of one image's usable features. Feature-vector rows are indices into
// the image's FeatureSet (not into the subset that was encoded).
struct BowEncoding {
  BowVector bow;
  FeatureVector features;
};

struct KeyframeCandidate {
  map::Keyframe* keyframe = nullptr;
  double score = 0;      // Vocabulary::score with the query, in [0, 1]
  int shared_words = 0;  // words present in both
};

class KeyframeDatabase {
 public:
  // direct_index_level: vocabulary tree level (root = 0) whose nodes group features for matching;
  // 2 gives up to k^2 = 100 groups for k = 10. Throws InputError for an empty/null vocabulary,
  // ConfigError for a level outside [0, depth] (relocalisation.direct_index_level).
  KeyframeDatabase(std::shared_ptr<const Vocabulary> vocabulary, int direct_index_level);

  // Encodes the features whose status is kStatic (dynamic ones would recall places by the people
  // in them). No lock taken: callable from any thread.
  BowEncoding encode(const map::FeatureSet& features, const std::vector<map::FeatureStatus>& status) const;

  // Adds (or replaces) kf: encodes its usable features (outside the lock), then inserts.
  void add(map::Keyframe* kf);
  void add(map::Keyframe* kf, BowEncoding encoding);
  // Removes a keyframe (e.g. culled by local mapping); false when it was not there.
  bool erase(uint64_t keyframe_id);
  void clear();

  // Keyframes sharing words with `bow`, best score first (BowQueryOptions: max_results,
  // min_shared_words, filter by keyframe id; the filter runs under the lock and must not call
  // back into the database).
  std::vector<KeyframeCandidate> query(const BowVector& bow, const BowQueryOptions& options = {}) const;

  std::optional<BowVector> bowVector(uint64_t keyframe_id) const;
  std::optional<FeatureVector> featureVector(uint64_t keyframe_id) const;
  bool contains(uint64_t keyframe_id) const;
  std::size_t size() const;

  const Vocabulary& vocabulary() const { return *vocabulary_; }
  int directIndexLevel() const { return direct_index_level_; }

 private:
  std::shared_ptr<const Vocabulary> vocabulary_;  // immutable
  int direct_index_level_;                         // immutable
  mutable std::mutex mutex_;                       // guards keyframes_; taken before bow_'s own
  BowDatabase bow_;
  std::unordered_map<uint64_t, map::Keyframe*> keyframes_;
};

}  // namespace desslam::place
