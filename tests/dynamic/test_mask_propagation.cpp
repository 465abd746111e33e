// MaskPropagator on a constructed sequence: a textured square sliding right over a static
// textured background. The square's frame-0 mask carried along the flow must follow it; the
// bookkeeping (newest frame, history, gaps in the ids, the cache) must hold.
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "dynamic/mask_propagation.hpp"

namespace desslam::dynamic {
namespace {

constexpr int kSide = 90;          // the square, pixels
constexpr int kStepPx = 4;         // its motion per frame, to the right
const cv::Point kStart(200, 180);  // its top-left corner in frame 0
const cv::Size kFrameSize(640, 480);

// Random texture, blurred a little so the flow (on 4x smaller images) has gradients to follow.
cv::Mat texture(cv::Size size, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat t(size, CV_8UC1);
  rng.fill(t, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(t, t, cv::Size(0, 0), 2.0);
  cv::normalize(t, t, 0, 255, cv::NORM_MINMAX);
  return t;
}

cv::Rect squareAt(int frame) { return {kStart.x + kStepPx * frame, kStart.y, kSide, kSide}; }

class SlidingSquare {
 public:
  SlidingSquare() : background_(texture(kFrameSize, 11)), square_(texture({kSide, kSide}, 22)) {}

  cv::Mat frame(int k) const {
    cv::Mat image = background_.clone();
    square_.copyTo(image(squareAt(k)));
    return image;
  }
  // The true mask of frame k, 0/255.
  static cv::Mat mask(int k) {
    cv::Mat m(kFrameSize, CV_8UC1, cv::Scalar(0));
    m(squareAt(k)).setTo(255);
    return m;
  }

 private:
  cv::Mat background_, square_;
};

double iou(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat both, either;
  cv::bitwise_and(a > 0, b > 0, both);
  cv::bitwise_or(a > 0, b > 0, either);
  const int u = cv::countNonZero(either);
  return u > 0 ? double(cv::countNonZero(both)) / u : 0.0;
}

int differingPixels(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat x;
  cv::bitwise_xor(a > 0, b > 0, x);
  return cv::countNonZero(x);
}

void addFrames(MaskPropagator& propagator, const SlidingSquare& sequence, int first, int last) {
  for (int k = first; k <= last; ++k) propagator.addFrame(static_cast<uint64_t>(k), sequence.frame(k));
}

// Share of the true mask's pixels that `carried` covers (what the header's Bonn figures measure).
double coverage(const cv::Mat& carried, const cv::Mat& truth) {
  cv::Mat both;
  cv::bitwise_and(carried > 0, truth > 0, both);
  return double(cv::countNonZero(both)) / cv::countNonZero(truth);
}

double centreX(const cv::Mat& mask) {
  const cv::Moments m = cv::moments(mask, true);
  return m.m00 > 0 ? m.m10 / m.m00 : -1.0;
}

TEST(MaskPropagator, CarriedMaskFollowsTheMovingSquare) {
  const SlidingSquare sequence;
  MaskPropagator propagator;
  addFrames(propagator, sequence, 0, 6);
  const cv::Mat carried = propagator.carry(0, SlidingSquare::mask(0));
  ASSERT_FALSE(carried.empty());
  ASSERT_EQ(carried.type(), CV_8UC1);
  ASSERT_EQ(carried.size(), kFrameSize);

  const cv::Mat source = SlidingSquare::mask(0), truth = SlidingSquare::mask(6);
  const double carried_iou = iou(carried, truth), left_in_place_iou = iou(source, truth);
  const double carried_coverage = coverage(carried, truth), left_in_place_coverage = coverage(source, truth);
  const double shift = centreX(carried) - centreX(source), true_shift = 6.0 * kStepPx;
  RecordProperty("carried_iou", std::to_string(carried_iou));
  RecordProperty("left_in_place_iou", std::to_string(left_in_place_iou));
  RecordProperty("carried_coverage", std::to_string(carried_coverage));
  RecordProperty("shift_px", std::to_string(shift));
  // The flow underestimates a 90 px object's motion: DIS's ultrafast preset stops two pyramid
  // levels above the 4x-reduced image, so the flow field is 40x30 and its 8 px patches are wider
  // than the square (5.6 px there); they average its motion with the static background's. Measured
  // here: shift about 9 of 24 px, IoU 0.71 (left in place 0.58). Hence no IoU > 0.75: the test holds
  // the carry to clearly beating the mask left in place, moving the right way, keeping its size.
  EXPECT_GT(carried_iou, left_in_place_iou + 0.08) << "carried " << carried_iou << ", left in place "
                                                   << left_in_place_iou;
  EXPECT_GT(carried_coverage, left_in_place_coverage + 0.05);
  EXPECT_GT(shift, 0.25 * true_shift) << "the carried mask must move with the square";
  EXPECT_LT(shift, 1.25 * true_shift);
  EXPECT_NEAR(cv::countNonZero(carried), kSide * kSide, 0.15 * kSide * kSide) << "carried, not smeared";
}

TEST(MaskPropagator, LargeSquareIsCarriedMostOfTheWay) {
  // Person-sized (the Bonn crowd's people are 150-300 px wide): the flow resolves its motion.
  constexpr int kLargeSide = 200;
  const cv::Mat background = texture(kFrameSize, 11), square = texture({kLargeSide, kLargeSide}, 22);
  const auto at = [&](int k) { return cv::Rect(150 + kStepPx * k, 140, kLargeSide, kLargeSide); };
  const auto maskAt = [&](int k) {
    cv::Mat m(kFrameSize, CV_8UC1, cv::Scalar(0));
    m(at(k)).setTo(255);
    return m;
  };
  MaskPropagator propagator;
  for (int k = 0; k <= 6; ++k) {
    cv::Mat image = background.clone();
    square.copyTo(image(at(k)));
    propagator.addFrame(static_cast<uint64_t>(k), image);
  }
  const cv::Mat carried = propagator.carry(0, maskAt(0));
  ASSERT_FALSE(carried.empty());
  const double carried_iou = iou(carried, maskAt(6)), left_in_place_iou = iou(maskAt(0), maskAt(6));
  RecordProperty("carried_iou", std::to_string(carried_iou));
  EXPECT_GT(carried_iou, 0.85);
  EXPECT_GT(carried_iou, left_in_place_iou + 0.05);
  EXPECT_GT(coverage(carried, maskAt(6)), 0.9);
}

TEST(MaskPropagator, NewestFramesOwnMaskComesBackUnchanged) {
  const SlidingSquare sequence;
  MaskPropagator propagator;
  addFrames(propagator, sequence, 0, 3);
  const cv::Mat mask = SlidingSquare::mask(3);
  const cv::Mat carried = propagator.carry(3, mask);
  ASSERT_EQ(carried.size(), kFrameSize);
  ASSERT_EQ(carried.type(), CV_8UC1);
  EXPECT_EQ(differingPixels(carried, mask), 0);
  // Any nonzero value is dynamic, and comes back as 255.
  cv::Mat ones(kFrameSize, CV_8UC1, cv::Scalar(0));
  ones(squareAt(3)).setTo(1);
  const cv::Mat as_255 = propagator.carry(3, ones);
  EXPECT_EQ(cv::countNonZero(as_255 == 255), kSide * kSide);
  EXPECT_EQ(cv::countNonZero((as_255 != 255) & (as_255 != 0)), 0);
  // A source newer than the newest frame cannot be carried.
  EXPECT_TRUE(propagator.carry(4, mask).empty());
}

TEST(MaskPropagator, SourceOlderThanTheHistoryGivesNothing) {
  const SlidingSquare sequence;
  MaskPropagator propagator(4, 3);  // three flow steps kept
  addFrames(propagator, sequence, 0, 5);
  EXPECT_TRUE(propagator.carry(0, SlidingSquare::mask(0)).empty());
  EXPECT_TRUE(propagator.carry(1, SlidingSquare::mask(1)).empty());
  // Frame 2 is exactly three steps back: still carried.
  const cv::Mat carried = propagator.carry(2, SlidingSquare::mask(2));
  ASSERT_FALSE(carried.empty());
  EXPECT_GT(iou(carried, SlidingSquare::mask(5)), iou(SlidingSquare::mask(2), SlidingSquare::mask(5)));
}

TEST(MaskPropagator, AGapInTheFrameIdsRestartsTheHistory) {
  const SlidingSquare sequence;
  MaskPropagator propagator;
  addFrames(propagator, sequence, 0, 6);
  ASSERT_FALSE(propagator.carry(3, SlidingSquare::mask(3)).empty());
  propagator.addFrame(10, sequence.frame(10));  // frames 7-9 never added
  EXPECT_TRUE(propagator.carry(3, SlidingSquare::mask(3)).empty());
  EXPECT_TRUE(propagator.carry(6, SlidingSquare::mask(6)).empty());
  EXPECT_EQ(differingPixels(propagator.carry(10, SlidingSquare::mask(10)), SlidingSquare::mask(10)), 0);
  // The history starts again from frame 10.
  propagator.addFrame(11, sequence.frame(11));
  EXPECT_FALSE(propagator.carry(10, SlidingSquare::mask(10)).empty());
}

TEST(MaskPropagator, CachedCarryMatchesCarryingInOneGo) {
  // Real time carries the same (newest available) mask on every frame until a newer one arrives:
  // frame by frame through the cache must give what one carry over all the steps gives.
  const SlidingSquare sequence;
  const cv::Mat source = SlidingSquare::mask(1);
  MaskPropagator step_by_step;
  addFrames(step_by_step, sequence, 0, 2);
  cv::Mat carried;
  for (int k = 2; k <= 6; ++k) {
    if (k > 2) step_by_step.addFrame(static_cast<uint64_t>(k), sequence.frame(k));
    carried = step_by_step.carry(1, source);
    ASSERT_FALSE(carried.empty()) << "frame " << k;
  }
  // Asking twice on one frame changes nothing either.
  EXPECT_EQ(differingPixels(step_by_step.carry(1, source), carried), 0);

  MaskPropagator in_one_go;
  addFrames(in_one_go, sequence, 0, 6);
  const cv::Mat fresh = in_one_go.carry(1, source);
  ASSERT_FALSE(fresh.empty());
  EXPECT_EQ(differingPixels(carried, fresh), 0);
  EXPECT_GT(iou(carried, SlidingSquare::mask(6)), 0.75);
}

TEST(MaskPropagator, CarryingAnotherSourceDoesNotUseTheCache) {
  // After carrying frame 1's mask, frame 2's mask (a different square) must not come back as
  // frame 1's carried result.
  const SlidingSquare sequence;
  MaskPropagator propagator;
  addFrames(propagator, sequence, 0, 5);
  const cv::Mat from_one = propagator.carry(1, SlidingSquare::mask(1));
  cv::Mat elsewhere(kFrameSize, CV_8UC1, cv::Scalar(0));
  elsewhere(cv::Rect(20, 20, 60, 60)).setTo(255);  // static background: stays put
  const cv::Mat from_two = propagator.carry(2, elsewhere);
  ASSERT_FALSE(from_one.empty());
  ASSERT_FALSE(from_two.empty());
  EXPECT_GT(iou(from_two, elsewhere), 0.8);
  EXPECT_LT(iou(from_two, from_one), 0.1);
}

TEST(MaskPropagator, RejectsWrongInput) {
  EXPECT_THROW(MaskPropagator(0, 30), InputError);
  EXPECT_THROW(MaskPropagator(4, 0), InputError);
  const SlidingSquare sequence;
  MaskPropagator propagator;
  EXPECT_THROW(propagator.addFrame(0, cv::Mat()), InputError);
  EXPECT_THROW(propagator.addFrame(0, cv::Mat(kFrameSize, CV_8UC3, cv::Scalar::all(0))), InputError);
  addFrames(propagator, sequence, 0, 2);
  EXPECT_THROW(propagator.carry(0, cv::Mat(240, 320, CV_8UC1, cv::Scalar(0))), InputError);
  EXPECT_THROW(propagator.carry(0, cv::Mat(kFrameSize, CV_32FC1, cv::Scalar(0))), InputError);
  EXPECT_THROW(propagator.carry(0, cv::Mat()), InputError);
}

}  // namespace
}  // namespace desslam::dynamic
