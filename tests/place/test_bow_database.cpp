#include <algorithm>
#include <atomic>
#include <random>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "place/bow_database.hpp"
#include "place/vocabulary.hpp"

namespace desslam::place {
namespace {

BowVector normalised(BowVector v) {
  double sum = 0;
  for (auto& [w, x] : v) sum += x;
  for (auto& [w, x] : v) x /= sum;
  return v;
}

TEST(BowDatabase, QueryRanksByScoreAndCountsSharedWords) {
  BowDatabase db(10);
  db.add(1, {{0, 0.5}, {1, 0.5}});
  db.add(2, {{1, 0.5}, {2, 0.5}});
  db.add(3, {{5, 1.0}});
  const BowVector query{{0, 0.5}, {1, 0.5}};
  const auto results = db.query(query);
  ASSERT_EQ(results.size(), 2u);  // entry 3 shares no word
  EXPECT_EQ(results[0].id, 1u);
  EXPECT_NEAR(results[0].score, 1.0, 1e-12);
  EXPECT_EQ(results[0].shared_words, 2);
  EXPECT_EQ(results[1].id, 2u);
  EXPECT_NEAR(results[1].score, 0.5, 1e-12);
  EXPECT_EQ(results[1].shared_words, 1);

  EXPECT_EQ(db.query(query, 1).size(), 1u);
  const auto filtered = db.query(query, 0, [](uint64_t id) { return id != 1; });
  ASSERT_EQ(filtered.size(), 1u);
  EXPECT_EQ(filtered[0].id, 2u);

  BowQueryOptions options;
  options.min_shared_words = 2;
  const auto strict = db.query(query, options);
  ASSERT_EQ(strict.size(), 1u);
  EXPECT_EQ(strict[0].id, 1u);
}

TEST(BowDatabase, MatchesBruteForceScores) {
  std::mt19937 rng(17);
  const std::size_t words = 500;
  std::uniform_int_distribution<int> word(0, int(words) - 1);
  std::uniform_real_distribution<double> weight(0.01, 1.0);
  auto randomVector = [&] {
    BowVector v;
    for (int i = 0; i < 40; ++i) v[WordId(word(rng))] = weight(rng);
    return normalised(v);
  };
  BowDatabase db(words);
  std::vector<BowVector> entries;
  for (int i = 0; i < 200; ++i) {
    entries.push_back(randomVector());
    db.add(uint64_t(i), entries.back());
  }
  for (int q = 0; q < 10; ++q) {
    const BowVector query = randomVector();
    const auto results = db.query(query, 5);
    ASSERT_EQ(results.size(), 5u);
    std::vector<double> brute;
    for (const BowVector& e : entries) brute.push_back(Vocabulary::score(query, e));
    std::vector<double> sorted = brute;
    std::sort(sorted.rbegin(), sorted.rend());
    for (int k = 0; k < 5; ++k) {
      EXPECT_NEAR(results[k].score, brute[results[k].id], 1e-12);
      EXPECT_NEAR(results[k].score, sorted[k], 1e-12);
    }
  }
}

TEST(BowDatabase, EraseAndReplaceUpdateTheInvertedFile) {
  BowDatabase db(10);
  db.add(7, {{3, 0.25}, {4, 0.75}}, {{1, {0, 2}}});
  db.add(8, {{3, 1.0}});
  EXPECT_EQ(db.size(), 2u);
  EXPECT_EQ(db.entriesWithWord(3), 2u);
  ASSERT_TRUE(db.featureVector(7).has_value());
  EXPECT_EQ(db.featureVector(7)->at(1), (std::vector<int>{0, 2}));

  // Replacing entry 7 drops its old words.
  db.add(7, {{5, 1.0}});
  EXPECT_EQ(db.size(), 2u);
  EXPECT_EQ(db.entriesWithWord(3), 1u);
  EXPECT_EQ(db.entriesWithWord(4), 0u);
  EXPECT_TRUE(db.featureVector(7)->empty());

  EXPECT_TRUE(db.erase(8));
  EXPECT_FALSE(db.erase(8));
  EXPECT_FALSE(db.contains(8));
  EXPECT_EQ(db.entriesWithWord(3), 0u);
  EXPECT_TRUE(db.query({{3, 1.0}}).empty());
  EXPECT_EQ(db.bowVector(7), (BowVector{{5, 1.0}}));
  EXPECT_FALSE(db.bowVector(8).has_value());

  db.clear();
  EXPECT_EQ(db.size(), 0u);
  EXPECT_TRUE(db.query({{5, 1.0}}).empty());
}

TEST(BowDatabase, RejectsWordsOutsideTheVocabulary) {
  BowDatabase db(10);
  EXPECT_THROW(db.add(1, {{10, 1.0}}), InputError);
  EXPECT_EQ(db.size(), 0u);
  EXPECT_TRUE(db.query({{12, 1.0}}).empty());  // queries simply find nothing
}

TEST(ForEachSharedNode, VisitsNodesPresentInBoth) {
  const FeatureVector a{{1, {0}}, {4, {1, 2}}, {9, {3}}, {12, {4}}};
  const FeatureVector b{{2, {0}}, {4, {5}}, {12, {6, 7}}, {20, {8}}};
  std::vector<NodeId> visited;
  forEachSharedNode(a, b, [&](NodeId node, const std::vector<int>& ra, const std::vector<int>& rb) {
    visited.push_back(node);
    EXPECT_EQ(ra, a.at(node));
    EXPECT_EQ(rb, b.at(node));
  });
  EXPECT_EQ(visited, (std::vector<NodeId>{4, 12}));
}

// Several threads adding, querying and erasing at once (run under TSan to check the locking).
TEST(BowDatabase, ConcurrentUseKeepsAConsistentState) {
  BowDatabase db(100);
  std::atomic<int> failures{0};
  auto writer = [&](uint64_t first) {
    for (uint64_t id = first; id < first + 200; ++id) {
      db.add(id, {{WordId(id % 100), 1.0}});
      if (id % 2 == 0) db.erase(id);
    }
  };
  auto reader = [&] {
    for (int i = 0; i < 300; ++i)
      for (const auto& r : db.query({{WordId(i % 100), 1.0}}, 3))
        if (r.score != 1.0 || r.shared_words != 1) ++failures;  // every entry holds one word, weight 1
  };
  std::vector<std::thread> threads;
  threads.emplace_back(writer, 0);
  threads.emplace_back(writer, 1000);
  threads.emplace_back(reader);
  threads.emplace_back(reader);
  for (auto& t : threads) t.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(db.size(), 200u);  // the odd ids stay
  std::size_t postings = 0;
  for (WordId w = 0; w < 100; ++w) postings += db.entriesWithWord(w);
  EXPECT_EQ(postings, 200u);
}

}  // namespace
}  // namespace desslam::place
