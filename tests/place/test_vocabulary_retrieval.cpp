// Place recognition with the shipped vocabulary on real images it was not trained on: fr1_xyz
// (the vocabulary is trained on fr1_desk and Bonn crowd, see vocab/README.md).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "core/trajectory.hpp"
#include "eval/association.hpp"
#include "feature/orb_extractor.hpp"
#include "io/trajectory_io.hpp"
#include "place/bow_database.hpp"
#include "place/vocabulary.hpp"
#include "support/shared_data.hpp"

namespace desslam::place {
namespace {

namespace fs = std::filesystem;

constexpr int kKeyframeEvery = 5;
constexpr double kMaxTranslation = 0.3;  // metres
constexpr double kMaxRotationDeg = 30.0;
constexpr uint64_t kDistractorIds = 1000;

fs::path vocabularyPath() { return desslam::test::sourceDir() / "vocab" / "desslam_orb_k10l5.bin"; }

struct Keyframe {
  Timestamp timestamp = 0;
  fs::path image;
  SE3 T_w_c;
  BowVector bow;
};

// Every n-th RGB frame of a TUM-layout folder that has a ground-truth pose within 0.02 s.
std::vector<Keyframe> keyframesOf(const fs::path& clip) {
  std::ifstream list(clip / "rgb.txt");
  std::vector<Keyframe> all;
  std::string line;
  while (std::getline(list, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    Keyframe k;
    std::string file;
    fields >> k.timestamp >> file;
    k.image = clip / file;
    all.push_back(k);
  }
  Trajectory stamps;
  std::vector<Keyframe> picked;
  for (std::size_t i = 0; i < all.size(); i += kKeyframeEvery) {
    stamps.push_back({all[i].timestamp, SE3()});
    picked.push_back(all[i]);
  }
  const Trajectory gt = io::readTumTrajectory(clip / "groundtruth.txt");
  std::vector<Keyframe> keyframes;
  for (const eval::Match& m : eval::associate(gt, stamps, 0.02)) {
    picked[m.est_index].T_w_c = gt[m.gt_index].T_w_c;
    keyframes.push_back(picked[m.est_index]);
  }
  return keyframes;
}

void computeBow(const Vocabulary& vocabulary, std::vector<Keyframe>& keyframes) {
  const feature::OrbExtractor extractor{OrbOptions{}};
  for (Keyframe& k : keyframes) {
    const cv::Mat gray = cv::imread(k.image.string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(gray.empty()) << k.image;
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    extractor.extract(gray, keypoints, descriptors);
    vocabulary.transform(descriptors, k.bow);
    ASSERT_FALSE(k.bow.empty()) << k.image;
  }
}

TEST(VocabularyRetrieval, SecondHalfOfFr1XyzFindsNearbyFirstHalfKeyframes) {
  const fs::path xyz = desslam::test::clipDir("fr1_xyz_0000_0099");
  const fs::path bonn = desslam::test::clipDir("bonn_crowd_0300_0399");
  DESSLAM_REQUIRE_SHARED(xyz);
  DESSLAM_REQUIRE_SHARED(bonn);
  if (!fs::exists(vocabularyPath()))
    GTEST_SKIP() << "vocabulary missing: " << vocabularyPath() << " (train it as vocab/README.md says)";

  const Vocabulary vocabulary = Vocabulary::load(vocabularyPath());
  std::vector<Keyframe> keyframes = keyframesOf(xyz);
  ASSERT_GE(keyframes.size(), 16u);
  computeBow(vocabulary, keyframes);
  // Another place as distractors: a query that prefers them over its own room fails.
  std::vector<Keyframe> distractors = keyframesOf(bonn);
  ASSERT_FALSE(distractors.empty());
  computeBow(vocabulary, distractors);

  const std::size_t half = keyframes.size() / 2;
  BowDatabase database(vocabulary);
  for (std::size_t i = 0; i < half; ++i) database.add(i, keyframes[i].bow);
  for (std::size_t i = 0; i < distractors.size(); ++i) database.add(kDistractorIds + i, distractors[i].bow);

  int good = 0, queries = 0;
  for (std::size_t q = half; q < keyframes.size(); ++q) {
    ++queries;
    const auto results = database.query(keyframes[q].bow, 1);
    ASSERT_EQ(results.size(), 1u);
    const uint64_t id = results[0].id;
    if (id >= kDistractorIds) {
      std::cout << "query " << q << " retrieved a Bonn keyframe (score " << results[0].score << ")\n";
      continue;
    }
    const SE3 T_q_c = keyframes[q].T_w_c.inverse() * keyframes[id].T_w_c;
    const double dt = T_q_c.translation().norm();
    const double dr = T_q_c.rotationAngle() * 180.0 / M_PI;
    if (dt <= kMaxTranslation && dr <= kMaxRotationDeg) ++good;
    else std::cout << "query " << q << " -> " << id << ": " << dt << " m, " << dr << " deg\n";
  }
  std::cout << "retrieval: " << good << "/" << queries << " queries found a keyframe within " << kMaxTranslation
            << " m and " << kMaxRotationDeg << " deg\n";
  EXPECT_GE(double(good), 0.8 * queries);
}

}  // namespace
}  // namespace desslam::place
