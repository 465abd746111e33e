#include "place/keyframe_database.hpp"

#include <string>

#include "core/error.hpp"
#include "core/option_fields.hpp"

namespace desslam::place {

namespace {
const Vocabulary& requireVocabulary(const std::shared_ptr<const Vocabulary>& vocabulary) {
  if (vocabulary == nullptr || vocabulary->empty())
    throw InputError("KeyframeDatabase: the vocabulary is empty; load one (relocalisation.vocabulary) first");
  return *vocabulary;
}
}  // namespace

KeyframeDatabase::KeyframeDatabase(std::shared_ptr<const Vocabulary> vocabulary, int direct_index_level)
    : vocabulary_(std::move(vocabulary)),
      direct_index_level_(direct_index_level),
      bow_(requireVocabulary(vocabulary_)) {
  requireInRange("relocalisation", "direct_index_level", direct_index_level, 0, vocabulary_->depth());
}

BowEncoding KeyframeDatabase::encode(const map::FeatureSet& features,
                                     const std::vector<map::FeatureStatus>& status) const {
  std::vector<int> rows;
  rows.reserve(features.size());
  for (size_t i = 0; i < features.size(); ++i)
    if (i >= status.size() || status[i] == map::FeatureStatus::kStatic) rows.push_back(static_cast<int>(i));
  BowEncoding encoding;
  if (rows.empty()) return encoding;
  cv::Mat subset;
  if (rows.size() == features.size()) {
    subset = features.descriptors;
  } else {
    subset.create(static_cast<int>(rows.size()), features.descriptors.cols, features.descriptors.type());
    for (size_t k = 0; k < rows.size(); ++k) features.descriptors.row(rows[k]).copyTo(subset.row(static_cast<int>(k)));
  }
  vocabulary_->transform(subset, encoding.bow, encoding.features, vocabulary_->depth() - direct_index_level_);
  // Rows of the subset -> feature indices.
  if (rows.size() != features.size())
    for (auto& [node, members] : encoding.features)
      for (int& row : members) row = rows[static_cast<size_t>(row)];
  return encoding;
}

void KeyframeDatabase::add(map::Keyframe* kf) {
  if (kf == nullptr) throw InputError("KeyframeDatabase::add: null keyframe");
  add(kf, encode(*kf->features, kf->status));
}

void KeyframeDatabase::add(map::Keyframe* kf, BowEncoding encoding) {
  if (kf == nullptr) throw InputError("KeyframeDatabase::add: null keyframe");
  std::lock_guard lock(mutex_);
  bow_.add(kf->id, encoding.bow, std::move(encoding.features));
  keyframes_[kf->id] = kf;
}

bool KeyframeDatabase::erase(uint64_t keyframe_id) {
  std::lock_guard lock(mutex_);
  keyframes_.erase(keyframe_id);
  return bow_.erase(keyframe_id);
}

void KeyframeDatabase::clear() {
  std::lock_guard lock(mutex_);
  keyframes_.clear();
  bow_.clear();
}

std::vector<KeyframeCandidate> KeyframeDatabase::query(const BowVector& bow, const BowQueryOptions& options) const {
  std::lock_guard lock(mutex_);
  const std::vector<BowQueryResult> results = bow_.query(bow, options);
  std::vector<KeyframeCandidate> candidates;
  candidates.reserve(results.size());
  for (const BowQueryResult& r : results) {
    auto it = keyframes_.find(r.id);
    if (it != keyframes_.end()) candidates.push_back({it->second, r.score, r.shared_words});
  }
  return candidates;
}

std::optional<BowVector> KeyframeDatabase::bowVector(uint64_t keyframe_id) const { return bow_.bowVector(keyframe_id); }

std::optional<FeatureVector> KeyframeDatabase::featureVector(uint64_t keyframe_id) const {
  return bow_.featureVector(keyframe_id);
}

bool KeyframeDatabase::contains(uint64_t keyframe_id) const {
  std::lock_guard lock(mutex_);
  return keyframes_.count(keyframe_id) > 0;
}

std::size_t KeyframeDatabase::size() const {
  std::lock_guard lock(mutex_);
  return keyframes_.size();
}

}  // namespace desslam::place
