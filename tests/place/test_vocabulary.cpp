#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.hpp"
#include "place/descriptor_clusters.hpp"
#include "place/vocabulary.hpp"

namespace desslam::place {
namespace {

using test::Bits;

// Well separated random centres (pairwise Hamming distance ~128) with samples within 8 bits.
struct ClusteredData {
  std::vector<Bits> centers;
  std::vector<std::vector<Bits>> samples;  // per centre
};

ClusteredData makeClusters(int count, int per_cluster, int flips, unsigned seed) {
  std::mt19937 rng(seed);
  ClusteredData data;
  for (int c = 0; c < count; ++c) {
    data.centers.push_back(test::randomBits(rng));
    data.samples.emplace_back();
    for (int i = 0; i < per_cluster; ++i) data.samples.back().push_back(test::flipBits(data.centers.back(), flips, rng));
  }
  return data;
}

std::filesystem::path tempFile(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("desslam_loop_" + std::to_string(::getpid()) + "_" + name);
}

TEST(VocabularyOptions, RejectsBadValuesNamingTheKey) {
  VocabularyOptions options;
  EXPECT_NO_THROW(options.validate());
  options.branching = 1;
  try {
    options.validate();
    FAIL() << "branching 1 accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("vocabulary.branching"), std::string::npos) << e.what();
  }
  options = {};
  options.depth = 0;
  EXPECT_THROW(options.validate(), ConfigError);
}

TEST(Vocabulary, KMeansFindsConstructedClusters) {
  const ClusteredData data = makeClusters(8, 40, 8, 11);
  // Each training image holds a few samples of every cluster.
  std::vector<cv::Mat> sets;
  for (int image = 0; image < 4; ++image) {
    std::vector<Bits> rows;
    for (const auto& cluster : data.samples)
      for (int i = image * 10; i < image * 10 + 10; ++i) rows.push_back(cluster[i]);
    sets.push_back(test::toMat(rows));
  }
  // Several seeds: the seeding must not put two centres into one cluster by bad luck.
  for (unsigned seed = 1; seed <= 5; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    VocabularyOptions options;
    options.branching = 8;
    options.depth = 1;
    options.seed = seed;
    const Vocabulary vocabulary = Vocabulary::train(sets, options);
    ASSERT_EQ(vocabulary.wordCount(), 8u);

    std::set<WordId> words;
    for (std::size_t c = 0; c < data.centers.size(); ++c) {
      const WordId word = vocabulary.wordOf(data.centers[c].data());
      words.insert(word);
      for (const Bits& sample : data.samples[c]) EXPECT_EQ(vocabulary.wordOf(sample.data()), word) << "cluster " << c;
      // Every image holds every word: IDF = ln(4/4) = 0.
      EXPECT_NEAR(vocabulary.wordWeight(word), 0.0, 1e-6);
    }
    EXPECT_EQ(words.size(), 8u) << "two constructed clusters share a word";
  }
}

TEST(Vocabulary, HierarchyGroupsSubclustersUnderOneNode) {
  // 3 groups far apart, each with 3 sub-clusters 40 bits from the group centre.
  std::mt19937 rng(5);
  std::vector<std::vector<Bits>> sub_centers(3);
  std::vector<Bits> rows;
  std::vector<std::pair<int, int>> label;  // (group, sub-cluster) per row
  for (int g = 0; g < 3; ++g) {
    const Bits group = test::randomBits(rng);
    for (int s = 0; s < 3; ++s) {
      sub_centers[g].push_back(test::flipBits(group, 40, rng));
      for (int i = 0; i < 30; ++i) {
        rows.push_back(test::flipBits(sub_centers[g][s], 4, rng));
        label.emplace_back(g, s);
      }
    }
  }
  VocabularyOptions options;
  options.branching = 3;
  options.depth = 2;
  const Vocabulary vocabulary = Vocabulary::train({test::toMat(rows)}, options);
  EXPECT_EQ(vocabulary.wordCount(), 9u);
  EXPECT_EQ(vocabulary.nodeCount(), 13u);  // root + 3 + 9

  // levels_up = 1: the direct index groups rows by their level-1 node, i.e. by group.
  BowVector bow;
  FeatureVector features;
  vocabulary.transform(test::toMat(rows), bow, features, 1);
  ASSERT_EQ(features.size(), 3u);
  for (const auto& [node, members] : features) {
    EXPECT_EQ(vocabulary.nodeLevel(node), 1);
    ASSERT_EQ(members.size(), 90u);
    for (int r : members) EXPECT_EQ(label[r].first, label[members.front()].first);
  }
  // levels_up = 0: grouped by word, i.e. by sub-cluster.
  vocabulary.transform(test::toMat(rows), bow, features, 0);
  ASSERT_EQ(features.size(), 9u);
  for (const auto& [node, members] : features) {
    EXPECT_EQ(vocabulary.nodeLevel(node), 2);
    for (int r : members) EXPECT_EQ(label[r], label[members.front()]);
  }
}

// Four words A, B, C, D; word w appears in n_w of the 4 training images.
class TfIdf : public ::testing::Test {
 protected:
  void SetUp() override {
    data_ = makeClusters(4, 40, 6, 21);
    // A in all 4 images, B in 2, C and D in 1 each.
    const std::vector<std::vector<int>> image_words{{0, 1}, {0, 1}, {0, 2}, {0, 3}};
    std::vector<cv::Mat> sets;
    std::vector<int> used(4, 0);
    for (const auto& words : image_words) {
      std::vector<Bits> rows;
      for (int w : words)
        for (int i = 0; i < 10; ++i) rows.push_back(data_.samples[w][used[w]++ % 40]);
      sets.push_back(test::toMat(rows));
    }
    VocabularyOptions options;
    options.branching = 4;
    options.depth = 1;
    vocabulary_ = Vocabulary::train(sets, options);
    ASSERT_EQ(vocabulary_.wordCount(), 4u);
    for (int w = 0; w < 4; ++w) word_[w] = vocabulary_.wordOf(data_.centers[w].data());
  }
  cv::Mat image(const std::vector<std::pair<int, int>>& word_counts) const {
    std::vector<Bits> rows;
    for (auto [w, n] : word_counts)
      for (int i = 0; i < n; ++i) rows.push_back(data_.samples[w][i]);
    return test::toMat(rows);
  }
  ClusteredData data_;
  Vocabulary vocabulary_;
  WordId word_[4]{};
};

TEST_F(TfIdf, IdfIsLogOfImagesOverImagesWithWord) {
  EXPECT_NEAR(vocabulary_.wordWeight(word_[0]), 0.0, 1e-6);
  EXPECT_NEAR(vocabulary_.wordWeight(word_[1]), std::log(2.0), 1e-6);
  EXPECT_NEAR(vocabulary_.wordWeight(word_[2]), std::log(4.0), 1e-6);
  EXPECT_NEAR(vocabulary_.wordWeight(word_[3]), std::log(4.0), 1e-6);
}

TEST_F(TfIdf, BowVectorIsNormalisedTfIdf) {
  BowVector bow;
  vocabulary_.transform(image({{0, 3}, {1, 1}, {2, 2}}), bow);
  // A has zero weight and is left out; B: 1 * ln2, C: 2 * ln4 = 4 ln2 => 0.2 and 0.8.
  ASSERT_EQ(bow.size(), 2u);
  EXPECT_EQ(bow.count(word_[0]), 0u);
  EXPECT_NEAR(bow.at(word_[1]), 0.2, 1e-9);
  EXPECT_NEAR(bow.at(word_[2]), 0.8, 1e-9);

  BowVector other;
  vocabulary_.transform(image({{1, 1}, {3, 1}}), other);
  // B: ln2, D: ln4 => 1/3 and 2/3; shared word B: min(0.2, 1/3) = 0.2.
  EXPECT_NEAR(other.at(word_[1]), 1.0 / 3.0, 1e-9);
  EXPECT_NEAR(Vocabulary::score(bow, other), 0.2, 1e-9);
  EXPECT_NEAR(Vocabulary::score(bow, bow), 1.0, 1e-12);

  BowVector empty;
  vocabulary_.transform(cv::Mat(), empty);
  EXPECT_TRUE(empty.empty());
}

TEST(VocabularyScore, EqualsOneMinusHalfL1Distance) {
  std::mt19937 rng(3);
  auto randomVector = [&] {
    BowVector v;
    std::uniform_int_distribution<int> word(0, 60);
    std::uniform_real_distribution<double> weight(0.01, 1.0);
    for (int i = 0; i < 25; ++i) v[WordId(word(rng))] = weight(rng);
    double sum = 0;
    for (auto& [w, x] : v) sum += x;
    for (auto& [w, x] : v) x /= sum;
    return v;
  };
  for (int trial = 0; trial < 50; ++trial) {
    const BowVector a = randomVector(), b = randomVector();
    double l1 = 0;
    for (WordId w = 0; w <= 60; ++w) {
      const double x = a.count(w) ? a.at(w) : 0.0, y = b.count(w) ? b.at(w) : 0.0;
      l1 += std::abs(x - y);
    }
    EXPECT_NEAR(Vocabulary::score(a, b), 1.0 - 0.5 * l1, 1e-12);
    EXPECT_NEAR(Vocabulary::score(a, b), Vocabulary::score(b, a), 1e-15);
  }
  EXPECT_EQ(Vocabulary::score({{1, 1.0}}, {{2, 1.0}}), 0.0);
}

TEST(Vocabulary, TrainRejectsBadInput) {
  VocabularyOptions options;
  EXPECT_THROW(Vocabulary::train({}, options), InputError);
  EXPECT_THROW(Vocabulary::train({cv::Mat()}, options), InputError);
  EXPECT_THROW(Vocabulary::train({cv::Mat(5, 32, CV_32F, cv::Scalar(0))}, options), InputError);
  EXPECT_THROW(Vocabulary::train({cv::Mat(5, 16, CV_8U, cv::Scalar(0))}, options), InputError);
  options.branching = 0;
  EXPECT_THROW(Vocabulary::train({cv::Mat(5, 32, CV_8U, cv::Scalar(0))}, options), ConfigError);
  const Vocabulary empty;
  BowVector bow;
  EXPECT_THROW(empty.transform(cv::Mat(1, 32, CV_8U, cv::Scalar(0)), bow), InputError);
}

TEST(Vocabulary, SubsampledTrainingStillCountsIdfOnAllImages) {
  const ClusteredData data = makeClusters(5, 100, 6, 8);
  std::vector<cv::Mat> sets;
  for (int image = 0; image < 10; ++image) {
    std::vector<Bits> rows;
    for (int c = 0; c < 5; ++c)
      for (int i = 0; i < 10; ++i) rows.push_back(data.samples[c][image * 10 + i]);
    sets.push_back(test::toMat(rows));
  }
  // A lone extra image holding cluster 0 only keeps IDF(cluster 0) = ln(11/11) and makes the
  // others ln(11/10).
  sets.push_back(test::toMat({data.samples[0][0]}));
  VocabularyOptions options;
  options.branching = 5;
  options.depth = 1;
  options.max_descriptors = 100;  // 100 of 501 descriptors
  const Vocabulary vocabulary = Vocabulary::train(sets, options);
  ASSERT_EQ(vocabulary.wordCount(), 5u);
  EXPECT_NEAR(vocabulary.wordWeight(vocabulary.wordOf(data.centers[0].data())), 0.0, 1e-6);
  EXPECT_NEAR(vocabulary.wordWeight(vocabulary.wordOf(data.centers[1].data())), std::log(11.0 / 10.0), 1e-6);
}

class VocabularyFile : public ::testing::Test {
 protected:
  void SetUp() override {
    const ClusteredData data = makeClusters(30, 20, 10, 2);
    std::vector<cv::Mat> sets;
    for (int image = 0; image < 6; ++image) {
      std::vector<Bits> rows;
      for (int c = image; c < 30; c += 2)
        for (const Bits& b : data.samples[c]) rows.push_back(b);
      sets.push_back(test::toMat(rows));
      all_rows_.insert(all_rows_.end(), rows.begin(), rows.end());
    }
    VocabularyOptions options;
    options.branching = 4;
    options.depth = 3;
    vocabulary_ = Vocabulary::train(sets, options);
    path_ = tempFile(std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".bin");
    vocabulary_.save(path_);
  }
  void TearDown() override { std::filesystem::remove(path_); }

  std::vector<uint8_t> bytes() const {
    std::ifstream f(path_, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  }
  void writeBytes(const std::vector<uint8_t>& b) const {
    std::ofstream(path_, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(b.data()), b.size());
  }
  // load() must throw InputError whose message names the file and contains `phrase`.
  void expectLoadError(const std::string& phrase) const {
    try {
      Vocabulary::load(path_);
      FAIL() << "loaded a broken file (expected: " << phrase << ")";
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(path_.string()), std::string::npos) << message;
      EXPECT_NE(message.find(phrase), std::string::npos) << message;
    }
  }

  Vocabulary vocabulary_;
  std::vector<Bits> all_rows_;
  std::filesystem::path path_;
};

TEST_F(VocabularyFile, RoundTripKeepsTreeAndWeights) {
  const Vocabulary loaded = Vocabulary::load(path_);
  EXPECT_EQ(loaded.wordCount(), vocabulary_.wordCount());
  EXPECT_EQ(loaded.nodeCount(), vocabulary_.nodeCount());
  EXPECT_EQ(loaded.branching(), 4);
  EXPECT_EQ(loaded.depth(), 3);
  for (WordId w = 0; w < loaded.wordCount(); ++w)
    EXPECT_FLOAT_EQ(float(loaded.wordWeight(w)), float(vocabulary_.wordWeight(w)));
  BowVector a, b;
  FeatureVector fa, fb;
  const cv::Mat rows = test::toMat(all_rows_);
  vocabulary_.transform(rows, a, fa, 1);
  loaded.transform(rows, b, fb, 1);
  EXPECT_EQ(a, b);
  EXPECT_EQ(fa, fb);
}

TEST_F(VocabularyFile, MissingFileIsNamed) {
  std::filesystem::remove(path_);
  expectLoadError("cannot open");
}

TEST_F(VocabularyFile, BadMagicIsRejected) {
  std::vector<uint8_t> b = bytes();
  b[0] = 'X';
  writeBytes(b);
  expectLoadError("bad magic");
}

TEST_F(VocabularyFile, UnknownVersionIsRejected) {
  std::vector<uint8_t> b = bytes();
  b[8] = 7;  // version field follows the 8-byte magic
  writeBytes(b);
  expectLoadError("version 7");
}

TEST_F(VocabularyFile, TruncationIsRejected) {
  std::vector<uint8_t> b = bytes();
  b.resize(b.size() - 50);
  writeBytes(b);
  expectLoadError("truncated");
  b.resize(20);
  writeBytes(b);
  expectLoadError("truncated");
}

TEST_F(VocabularyFile, CorruptionFailsChecksum) {
  std::vector<uint8_t> b = bytes();
  b[b.size() / 2] ^= 0x10;
  writeBytes(b);
  expectLoadError("checksum");
}

}  // namespace
}  // namespace desslam::place
