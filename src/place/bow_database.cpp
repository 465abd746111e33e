#include "place/bow_database.hpp"

#include <algorithm>
#include <string>

#include "core/error.hpp"
#include "place/vocabulary.hpp"

namespace desslam::place {

BowDatabase::BowDatabase(std::size_t word_count) : inverted_(word_count) {}

BowDatabase::BowDatabase(const Vocabulary& vocabulary) : BowDatabase(vocabulary.wordCount()) {}

void BowDatabase::add(uint64_t id, const BowVector& bow, FeatureVector features) {
  if (!bow.empty() && bow.rbegin()->first >= inverted_.size())
    throw InputError("BowDatabase::add: word id " + std::to_string(bow.rbegin()->first) + " of entry " +
                     std::to_string(id) + " is outside the vocabulary (" + std::to_string(inverted_.size()) +
                     " words); use the vocabulary the database was made for");
  std::lock_guard lock(mutex_);
  eraseLocked(id);
  for (const auto& [word, weight] : bow) inverted_[word].push_back({id, weight});
  entries_.emplace(id, Entry{bow, std::move(features)});
}

bool BowDatabase::erase(uint64_t id) {
  std::lock_guard lock(mutex_);
  const bool present = entries_.count(id) > 0;
  eraseLocked(id);
  return present;
}

void BowDatabase::eraseLocked(uint64_t id) {
  auto it = entries_.find(id);
  if (it == entries_.end()) return;
  for (const auto& [word, weight] : it->second.bow) {
    std::vector<Posting>& postings = inverted_[word];
    std::erase_if(postings, [id](const Posting& p) { return p.id == id; });
  }
  entries_.erase(it);
}

void BowDatabase::clear() {
  std::lock_guard lock(mutex_);
  for (auto& postings : inverted_) postings.clear();
  entries_.clear();
}

std::vector<BowQueryResult> BowDatabase::query(const BowVector& bow, const BowQueryOptions& options) const {
  std::unordered_map<uint64_t, BowQueryResult> candidates;
  {
    std::lock_guard lock(mutex_);
    // L1 score of unit-norm vectors = sum over shared words of min(q_w, d_w) (see
    // Vocabulary::score), so walking the query's inverted lists is enough.
    for (const auto& [word, q_weight] : bow) {
      if (word >= inverted_.size()) continue;  // no entry can hold it
      for (const Posting& posting : inverted_[word]) {
        BowQueryResult& result = candidates[posting.id];
        result.id = posting.id;
        result.score += std::min(q_weight, posting.weight);
        ++result.shared_words;
      }
    }
    if (options.filter)
      std::erase_if(candidates, [&](const auto& item) { return !options.filter(item.first); });
  }
  std::vector<BowQueryResult> results;
  results.reserve(candidates.size());
  for (auto& [id, result] : candidates) {
    if (result.shared_words < options.min_shared_words) continue;
    result.score = std::clamp(result.score, 0.0, 1.0);
    results.push_back(result);
  }
  auto better = [](const BowQueryResult& a, const BowQueryResult& b) {
    return a.score != b.score ? a.score > b.score : a.id < b.id;
  };
  if (options.max_results > 0 && results.size() > std::size_t(options.max_results)) {
    std::partial_sort(results.begin(), results.begin() + options.max_results, results.end(), better);
    results.resize(std::size_t(options.max_results));
  } else {
    std::sort(results.begin(), results.end(), better);
  }
  return results;
}

std::vector<BowQueryResult> BowDatabase::query(const BowVector& bow, int max_results,
                                               const std::function<bool(uint64_t)>& filter) const {
  BowQueryOptions options;
  options.max_results = max_results;
  options.filter = filter;
  return query(bow, options);
}

bool BowDatabase::contains(uint64_t id) const {
  std::lock_guard lock(mutex_);
  return entries_.count(id) > 0;
}

std::size_t BowDatabase::size() const {
  std::lock_guard lock(mutex_);
  return entries_.size();
}

std::size_t BowDatabase::entriesWithWord(WordId word) const {
  std::lock_guard lock(mutex_);
  return word < inverted_.size() ? inverted_[word].size() : 0;
}

std::optional<BowVector> BowDatabase::bowVector(uint64_t id) const {
  std::lock_guard lock(mutex_);
  auto it = entries_.find(id);
  if (it == entries_.end()) return std::nullopt;
  return it->second.bow;
}

std::optional<FeatureVector> BowDatabase::featureVector(uint64_t id) const {
  std::lock_guard lock(mutex_);
  auto it = entries_.find(id);
  if (it == entries_.end()) return std::nullopt;
  return it->second.features;
}

}  // namespace desslam::place
