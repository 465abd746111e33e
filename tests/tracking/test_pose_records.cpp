// guessesBetweenMeasuredPoses (rule 1 of Tracker::interpolateAcrossMerges) on hand-made records:
// which guessed frames of a loss are interpolated between the measured frames around them.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "tracking/tracker.hpp"

namespace desslam::tracking {
namespace {

constexpr double kFramePeriodS = 1.0 / 30;
constexpr double kMaxSpanS = 0.6;

// One record per letter, 30 Hz: 'T' tracked, 'B' backfilled, 'P' predicted, 'K' predicted
// backwards, 'N' no pose, 'I' interpolated; map_now gives each record's map (-1 without one).
std::vector<FrameRecord> records(const std::string& sources) {
  std::vector<FrameRecord> out;
  for (size_t k = 0; k < sources.size(); ++k) {
    FrameRecord r;
    r.frame_id = k;
    r.timestamp = static_cast<double>(k) * kFramePeriodS;
    switch (sources[k]) {
      case 'T': r.source = PoseSource::kTracked; break;
      case 'B': r.source = PoseSource::kBackfilled; break;
      case 'P': r.source = PoseSource::kPredicted; break;
      case 'K': r.source = PoseSource::kPredictedBackwards; break;
      case 'I': r.source = PoseSource::kInterpolated; break;
      default: r.source = PoseSource::kNone; break;
    }
    out.push_back(r);
  }
  return out;
}

std::string describe(const std::vector<MeasuredPair>& pairs) {
  std::string s;
  for (const MeasuredPair& p : pairs) s += std::to_string(p.before) + "-" + std::to_string(p.after) + " ";
  return s;
}

void expectOnePair(const std::vector<MeasuredPair>& pairs, size_t before, size_t after) {
  ASSERT_EQ(pairs.size(), 1u) << describe(pairs);
  EXPECT_EQ(pairs[0].before, before);
  EXPECT_EQ(pairs[0].after, after);
}

TEST(PoseRecords, PredictionsBetweenTwoMeasuredPosesInOneMapAreInterpolatedBetweenThem) {
  expectOnePair(guessesBetweenMeasuredPoses(records("TTPPKKBT"), {0, 0, 0, 0, 0, 0, 0, 0}, kMaxSpanS), 1, 6);
}

TEST(PoseRecords, MeasuredPosesInTwoMapsAreNotInterpolatedBetween) {
  const auto r = records("TPPPT");
  EXPECT_TRUE(guessesBetweenMeasuredPoses(r, {0, 0, 0, 1, 1}, kMaxSpanS).empty());
}

// A map started in the loss and lost again after one frame, never merged (map 1), between two
// frames of map 0 (the first map, and the map the loss ended in, merged into it): the guesses
// around that frame are interpolated between the two frames of map 0; its own pose stays.
TEST(PoseRecords, AFrameMeasuredInAnotherMapDoesNotKeepTheGuessesAroundItFromInterpolation) {
  expectOnePair(guessesBetweenMeasuredPoses(records("TPPPPTKT"), {0, 0, 0, 0, 0, 1, 0, 0}, kMaxSpanS), 0, 7);
  // Without the guesses between, two measured frames of one map with another map's between need
  // nothing interpolated.
  EXPECT_TRUE(guessesBetweenMeasuredPoses(records("TTT"), {0, 1, 0}, kMaxSpanS).empty());
}

TEST(PoseRecords, GuessesFartherApartThanTheSpanOrAroundAnInterpolatedFrameAreLeft) {
  // 19 guesses: the measured frames 0.667 s apart.
  const auto far = records("T" + std::string(19, 'P') + "T");
  EXPECT_TRUE(guessesBetweenMeasuredPoses(far, std::vector<int>(far.size(), 0), kMaxSpanS).empty());
  const auto near = records("T" + std::string(16, 'P') + "T");
  EXPECT_EQ(guessesBetweenMeasuredPoses(near, std::vector<int>(near.size(), 0), kMaxSpanS).size(), 1u);
  // settle() interpolated a frame between other poses: the run is left as it is.
  const auto settled = records("TPIPT");
  EXPECT_TRUE(guessesBetweenMeasuredPoses(settled, {0, 0, 0, 0, 0}, kMaxSpanS).empty());
}

TEST(PoseRecords, OneMapIdPerRecordIsRequired) {
  EXPECT_THROW(guessesBetweenMeasuredPoses(records("TPT"), {0, 0}, kMaxSpanS), std::invalid_argument);
}

}  // namespace
}  // namespace desslam::tracking
