#include <algorithm>
#include <atomic>
#include <memory>
#include <random>
#include <set>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "place/keyframe_database.hpp"
#include "place/vocabulary_location.hpp"
#include "map/map_types.hpp"

namespace desslam::place {
namespace {

// The shipped vocabulary (vocab/): the database is meant to run with it.
std::shared_ptr<const Vocabulary> shippedVocabulary() {
  static const std::shared_ptr<const Vocabulary> vocabulary = loadVocabulary("");
  return vocabulary;
}

std::shared_ptr<const map::FeatureSet> randomFeatures(int count, std::mt19937& rng) {
  auto features = std::make_shared<map::FeatureSet>();
  features->descriptors.create(count, 32, CV_8U);
  cv::randu(features->descriptors, 0, 256);  // uses OpenCV's RNG; reseeded below per call
  std::uniform_real_distribution<float> u(0, 640);
  for (int i = 0; i < count; ++i) features->keypoints.emplace_back(u(rng), u(rng) * 0.75f, 31.0f);
  return features;
}

std::unique_ptr<map::Keyframe> makeKeyframe(uint64_t id, std::shared_ptr<const map::FeatureSet> features,
                                            std::vector<map::FeatureStatus> status = {}) {
  if (status.empty()) status.assign(features->size(), map::FeatureStatus::kStatic);
  return std::make_unique<map::Keyframe>(id, id * 10, 1000.0 + id, "kf" + std::to_string(id), std::move(features),
                                         std::move(status), cv::Mat(), SE3());
}

class KeyframeDatabaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    cv::theRNG().state = 12345;
    for (uint64_t id = 0; id < 4; ++id) keyframes_.push_back(makeKeyframe(id, randomFeatures(300, rng_)));
  }
  std::mt19937 rng_{3};
  std::vector<std::unique_ptr<map::Keyframe>> keyframes_;
};

TEST_F(KeyframeDatabaseTest, QueryFindsTheKeyframeWithTheSameWordsFirst) {
  KeyframeDatabase db(shippedVocabulary(), 2);
  for (auto& kf : keyframes_) db.add(kf.get());
  EXPECT_EQ(db.size(), 4u);
  for (auto& kf : keyframes_) {
    const BowEncoding query = db.encode(*kf->features, kf->status);
    const std::vector<KeyframeCandidate> results = db.query(query.bow);
    ASSERT_FALSE(results.empty());
    EXPECT_EQ(results.front().keyframe, kf.get());
    EXPECT_NEAR(results.front().score, 1.0, 1e-9);
    for (size_t k = 1; k < results.size(); ++k) EXPECT_LT(results[k].score, 0.5) << "random images share few words";
  }
  BowQueryOptions options;
  options.max_results = 1;
  options.filter = [](uint64_t id) { return id != 2; };
  const BowEncoding query = db.encode(*keyframes_[2]->features, keyframes_[2]->status);
  const auto filtered = db.query(query.bow, options);
  ASSERT_EQ(filtered.size(), 1u);
  EXPECT_NE(filtered.front().keyframe->id, 2u);
}

TEST_F(KeyframeDatabaseTest, EraseRemovesAKeyframeFromQueriesAndIndex) {
  KeyframeDatabase db(shippedVocabulary(), 2);
  for (auto& kf : keyframes_) db.add(kf.get());
  const BowEncoding query = db.encode(*keyframes_[1]->features, keyframes_[1]->status);
  EXPECT_TRUE(db.erase(1));
  EXPECT_FALSE(db.erase(1)) << "already gone";
  EXPECT_FALSE(db.contains(1));
  EXPECT_EQ(db.size(), 3u);
  EXPECT_FALSE(db.featureVector(1).has_value());
  EXPECT_FALSE(db.bowVector(1).has_value());
  for (const KeyframeCandidate& c : db.query(query.bow)) EXPECT_NE(c.keyframe->id, 1u);
  // Adding again restores it; adding twice replaces rather than duplicates.
  db.add(keyframes_[1].get());
  db.add(keyframes_[1].get());
  EXPECT_EQ(db.size(), 4u);
  const auto results = db.query(query.bow);
  ASSERT_FALSE(results.empty());
  EXPECT_EQ(results.front().keyframe->id, 1u);
  EXPECT_EQ(std::count_if(results.begin(), results.end(), [](const auto& c) { return c.keyframe->id == 1; }), 1);
  db.clear();
  EXPECT_EQ(db.size(), 0u);
  EXPECT_TRUE(db.query(query.bow).empty());
}

TEST_F(KeyframeDatabaseTest, DirectIndexHoldsExactlyTheStaticFeaturesAtTheChosenLevel) {
  const auto vocabulary = shippedVocabulary();
  KeyframeDatabase db(vocabulary, 2);
  std::vector<map::FeatureStatus> status(300, map::FeatureStatus::kStatic);
  for (size_t i = 0; i < status.size(); i += 3) status[i] = map::FeatureStatus::kDynamicStage1;
  auto kf = makeKeyframe(9, keyframes_[0]->features, status);
  db.add(kf.get());
  const auto nodes = db.featureVector(9);
  ASSERT_TRUE(nodes.has_value());
  std::set<int> indexed;
  for (const auto& [node, rows] : *nodes) {
    EXPECT_EQ(vocabulary->nodeLevel(node), 2) << "node " << node;
    for (int row : rows) EXPECT_TRUE(indexed.insert(row).second) << "feature " << row << " in two nodes";
  }
  std::set<int> expected;
  for (size_t i = 0; i < status.size(); ++i)
    if (status[i] == map::FeatureStatus::kStatic) expected.insert(static_cast<int>(i));
  EXPECT_EQ(indexed, expected) << "rows are feature indices of the static features";

  // Rows of one node really share the node: a feature's word lies under it. Check by encoding each
  // static feature alone at level 2.
  for (const auto& [node, rows] : *nodes) {
    for (int row : std::vector<int>(rows.begin(), rows.begin() + std::min<size_t>(rows.size(), 3))) {
      BowVector bow;
      FeatureVector single;
      vocabulary->transform(kf->features->descriptors.row(row), bow, single, vocabulary->depth() - 2);
      ASSERT_EQ(single.size(), 1u);
      EXPECT_EQ(single.begin()->first, node);
    }
  }
  // The dynamic features are not in the bag of words either: it equals that of the static subset.
  const auto bow = db.bowVector(9);
  ASSERT_TRUE(bow.has_value());
  cv::Mat static_rows;
  for (int i : expected) static_rows.push_back(kf->features->descriptors.row(i));
  BowVector expected_bow;
  vocabulary->transform(static_rows, expected_bow);
  EXPECT_EQ(bow->size(), expected_bow.size());
  EXPECT_NEAR(Vocabulary::score(*bow, expected_bow), 1.0, 1e-9);
}

TEST_F(KeyframeDatabaseTest, MappingThreadWritesWhileTrackingQueries) {
  KeyframeDatabase db(shippedVocabulary(), 2);
  std::vector<std::unique_ptr<map::Keyframe>> many;
  for (uint64_t id = 0; id < 40; ++id) many.push_back(makeKeyframe(100 + id, randomFeatures(150, rng_)));
  const BowEncoding query = db.encode(*many[0]->features, many[0]->status);
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int round = 0; round < 5; ++round) {
      for (auto& kf : many) db.add(kf.get());
      for (size_t k = 0; k < many.size(); k += 2) db.erase(many[k]->id);
    }
    done = true;
  });
  size_t queries = 0;
  while (!done) {
    for (const KeyframeCandidate& c : db.query(query.bow)) ASSERT_NE(c.keyframe, nullptr);
    ++queries;
  }
  writer.join();
  EXPECT_GT(queries, 0u);
  EXPECT_EQ(db.size(), many.size() / 2);  // the odd ones stayed
}

TEST(KeyframeDatabase, RejectsBadConstruction) {
  EXPECT_THROW(KeyframeDatabase(nullptr, 2), InputError);
  EXPECT_THROW(KeyframeDatabase(std::make_shared<const Vocabulary>(), 2), InputError);
  EXPECT_THROW(KeyframeDatabase(shippedVocabulary(), shippedVocabulary()->depth() + 1), ConfigError);
}

TEST(VocabularyLocation, ExplicitPathIsTheOnlyPlaceLookedAt) {
  std::vector<std::filesystem::path> tried;
  EXPECT_TRUE(resolveVocabularyPath("/nonexistent/vocab.bin", &tried).empty());
  ASSERT_EQ(tried.size(), 1u);
  try {
    loadVocabulary("/nonexistent/vocab.bin");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("relocalisation.vocabulary"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("/nonexistent/vocab.bin"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(resolveVocabularyPath("").empty()) << "the shipped vocabulary is found by default";
}

}  // namespace
}  // namespace desslam::place
