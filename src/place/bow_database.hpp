// Keyframe database for place recognition: an inverted file (word -> images containing it, with
// weights) that finds the images sharing words with a query without comparing against all of
// them, and a direct index (image -> feature vector) for descriptor matching between images.
//
// Thread safety: every method takes one internal mutex, so the loop closer, the tracker's
// relocalisation and the local mapper may call one database concurrently. Results are copies.
// The query filter runs with the mutex held: it must not call back into the database.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <vector>

#include "place/bow_types.hpp"

namespace desslam::place {

class Vocabulary;

struct BowQueryResult {
  uint64_t id = 0;
  double score = 0;      // Vocabulary::score of query and entry, in [0, 1]
  int shared_words = 0;  // words present in both
};

struct BowQueryOptions {
  int max_results = 0;       // best results kept; <= 0 keeps all
  int min_shared_words = 1;  // entries sharing fewer words are left out
  // Entries for which filter(id) is false are left out (e.g. the query keyframe's neighbours).
  std::function<bool(uint64_t id)> filter;
};

class BowDatabase {
 public:
  // word_count: size of the vocabulary the vectors come from (word ids must be below it).
  explicit BowDatabase(std::size_t word_count);
  explicit BowDatabase(const Vocabulary& vocabulary);

  // Adds (or replaces) entry `id`. features may be empty when no direct index is wanted.
  // Throws InputError when a word id is outside the vocabulary.
  void add(uint64_t id, const BowVector& bow, FeatureVector features = {});
  // Removes entry `id`; false when it was not there.
  bool erase(uint64_t id);
  void clear();

  // Entries sharing at least one word with `bow`, best score first (ties: smaller id first).
  std::vector<BowQueryResult> query(const BowVector& bow, const BowQueryOptions& options = {}) const;
  std::vector<BowQueryResult> query(const BowVector& bow, int max_results,
                                    const std::function<bool(uint64_t)>& filter = {}) const;

  bool contains(uint64_t id) const;
  std::size_t size() const;
  std::size_t wordCount() const { return inverted_.size(); }
  // Number of entries whose vector holds `word` (0 for ids outside the vocabulary).
  std::size_t entriesWithWord(WordId word) const;
  std::optional<BowVector> bowVector(uint64_t id) const;
  std::optional<FeatureVector> featureVector(uint64_t id) const;

 private:
  struct Posting {
    uint64_t id;
    double weight;
  };
  struct Entry {
    BowVector bow;
    FeatureVector features;
  };

  void eraseLocked(uint64_t id);

  mutable std::mutex mutex_;
  std::vector<std::vector<Posting>> inverted_;  // word -> entries holding it
  std::unordered_map<uint64_t, Entry> entries_;
};

}  // namespace desslam::place
