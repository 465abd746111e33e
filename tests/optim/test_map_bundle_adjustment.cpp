// optim::globalBundleAdjustment and its map <-> problem builder on a hand-built map::Map:
// keyframes sliding past a cloud of points, observed exactly where the true poses put them (plus
// half-pixel noise), keyframe poses and points perturbed before the solve.
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <shared_mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "feature/scale_pyramid.hpp"
#include "map/map.hpp"
#include "optim/map_bundle_adjustment.hpp"
#include "optim/synthetic_scene.hpp"

namespace desslam::optim {
namespace {

using test::rotationErrorDeg;
using test::translationError;

struct ObservedFeature {
  int point = -1;
  Vec2 uv;
  float depth = -1.0f;
};

// A FeatureSet whose feature i is the observation features[i] (level 0, no descriptor needed).
std::shared_ptr<const map::FeatureSet> featureSet(const std::vector<ObservedFeature>& features) {
  static const auto pyramid = std::make_shared<const feature::ScalePyramid>(feature::makeScalePyramid(8, 1.2));
  auto set = std::make_shared<map::FeatureSet>();
  for (const ObservedFeature& f : features) {
    set->keypoints.emplace_back(cv::Point2f(static_cast<float>(f.uv.x()), static_cast<float>(f.uv.y())), 31.0f,
                                0.0f, 50.0f, 0);
    set->uv.push_back(f.uv);
    set->depth.push_back(f.depth);
  }
  set->descriptors = cv::Mat(static_cast<int>(features.size()), 32, CV_8UC1, cv::Scalar(0));
  set->pyramid = pyramid;
  return set;
}

struct MapScene {
  map::Map map;
  std::vector<SE3> true_T_c_w;      // per keyframe, in id order
  std::vector<map::Keyframe*> keyframes;
  std::vector<Vec3> true_points;    // per scene point (not map point id)
  std::vector<map::MapPoint*> points;  // per scene point
  std::map<uint64_t, Vec3> true_by_id;  // per map point id
  map::MapPoint* outlier_point = nullptr;  // its observation in outlier_keyframe is 40 px off
  map::Keyframe* outlier_keyframe = nullptr;
};

// num_keyframes cameras 10 cm apart, points 2-5 m ahead, 0.5 px noise, 70 % with depth. Keyframe
// 0 starts at its true pose; the others 3 cm / 1 degree off, points 3 cm off.
std::unique_ptr<MapScene> makeMapScene(const PinholeCamera& camera, int num_keyframes, int num_points,
                                       unsigned seed) {
  auto s = std::make_unique<MapScene>();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1), bx(-1.5, 2.0), by(-1.2, 1.2), bz(2.0, 5.0);
  std::normal_distribution<double> pixel_noise(0, 0.5), point_noise(0, 0.03);
  for (int k = 0; k < num_keyframes; ++k) {
    const Mat3 R_w_c = so3Exp(Vec3(0.02 * k, 0.03 * std::sin(0.7 * k), 0.01 * k));
    s->true_T_c_w.push_back(SE3(R_w_c, Vec3(0.1 * k, 0.02 * std::sin(k), 0.05 * std::cos(0.5 * k))).inverse());
  }
  for (int p = 0; p < num_points; ++p) s->true_points.emplace_back(bx(rng), by(rng), bz(rng));

  // Observations per keyframe (feature index = position in the list).
  std::vector<std::vector<ObservedFeature>> observed(num_keyframes);
  for (int k = 0; k < num_keyframes; ++k) {
    for (int p = 0; p < num_points; ++p) {
      const Vec3 p_c = s->true_T_c_w[k] * s->true_points[p];
      const Vec2 uv = camera.project(p_c);
      if (p_c.z() < 0.5 || !camera.inImage(uv)) continue;
      ObservedFeature f{p, uv + Vec2(pixel_noise(rng), pixel_noise(rng))};
      if (unit(rng) < 0.7) f.depth = static_cast<float>(p_c.z() * (1.0 + 0.002 * pixel_noise(rng)));
      observed[k].push_back(f);
    }
  }
  // One gross outlier: a point every keyframe sees, 40 px off in keyframe 3.
  const int outlier_keyframe = 3;
  int outlier_feature = -1;
  for (size_t i = 0; i < observed[outlier_keyframe].size() && outlier_feature < 0; ++i) {
    const int p = observed[outlier_keyframe][i].point;
    int views = 0;
    for (const auto& list : observed)
      for (const auto& f : list) views += f.point == p ? 1 : 0;
    if (views == num_keyframes) outlier_feature = static_cast<int>(i);
  }
  if (outlier_feature >= 0) {
    observed[outlier_keyframe][outlier_feature].uv += Vec2(28.0, -28.0);
    observed[outlier_keyframe][outlier_feature].depth = -1.0f;  // a wrong match seen without depth
  }

  std::unique_lock lock(s->map.mutex());
  for (int k = 0; k < num_keyframes; ++k) {
    const SE3 start = k == 0 ? s->true_T_c_w[k] : test::perturb(s->true_T_c_w[k], rng, 0.03, M_PI / 180.0);
    auto features = featureSet(observed[k]);
    std::vector<map::FeatureStatus> status(features->size(), map::FeatureStatus::kStatic);
    s->keyframes.push_back(s->map.createKeyframe(static_cast<uint64_t>(10 * k), 1000.0 + k, "kf" + std::to_string(k),
                                                 features, status, cv::Mat(), start));
  }
  s->points.assign(num_points, nullptr);
  for (int k = 0; k < num_keyframes; ++k) {
    for (size_t i = 0; i < observed[k].size(); ++i) {
      const int p = observed[k][i].point;
      if (s->points[p] == nullptr) {
        const Vec3 start = s->true_points[p] + Vec3(point_noise(rng), point_noise(rng), point_noise(rng));
        s->points[p] = s->map.createPoint(start, s->keyframes[k]);
        s->true_by_id[s->points[p]->id] = s->true_points[p];
      }
      map::addObservation(s->points[p], s->keyframes[k], static_cast<int>(i));
    }
  }
  for (map::MapPoint* p : s->points)
    if (p != nullptr) map::updateNormalAndDepth(p);
  if (outlier_feature >= 0) {
    s->outlier_keyframe = s->keyframes[outlier_keyframe];
    s->outlier_point = s->keyframes[outlier_keyframe]->points[outlier_feature];
  }
  return s;
}

double meanPoseError(const MapScene& s) {
  double sum = 0;
  for (size_t k = 1; k < s.keyframes.size(); ++k) sum += translationError(s.keyframes[k]->T_c_w, s.true_T_c_w[k]);
  return sum / static_cast<double>(s.keyframes.size() - 1);
}

TEST(GlobalBundleAdjustment, PoseErrorDropsFirstKeyframeStaysAndOutlierIsErased) {
  const PinholeCamera camera = test::tumCamera();
  auto s = makeMapScene(camera, 8, 600, 11);
  ASSERT_NE(s->outlier_point, nullptr);
  ASSERT_TRUE(s->outlier_point->observations.count(s->outlier_keyframe->id));
  const SE3 first_before = s->keyframes[0]->T_c_w;
  const double error_before = meanPoseError(*s);

  BundleAdjustmentOptions options;
  const GlobalBaResult result = globalBundleAdjustment(s->map, camera, options);

  std::shared_lock lock(s->map.mutex());
  EXPECT_TRUE(result.completed);
  EXPECT_EQ(result.keyframes, 8u);
  EXPECT_GT(result.points, 500u);
  EXPECT_GE(result.outliers, 1u);

  const double error_after = meanPoseError(*s);
  std::printf("mean keyframe position error %.2f mm -> %.3f mm, %zu outliers of %zu observations\n",
              1000 * error_before, 1000 * error_after, result.outliers, result.observations);
  EXPECT_LT(error_after, error_before / 10) << error_before << " m -> " << error_after << " m";
  for (size_t k = 1; k < s->keyframes.size(); ++k) {
    EXPECT_LT(translationError(s->keyframes[k]->T_c_w, s->true_T_c_w[k]), 0.002) << "keyframe " << k;
    EXPECT_LT(rotationErrorDeg(s->keyframes[k]->T_c_w, s->true_T_c_w[k]), 0.05) << "keyframe " << k;
  }
  // The map's origin is the gauge: untouched, bit for bit.
  EXPECT_EQ(s->keyframes[0]->T_c_w.translation(), first_before.translation());
  EXPECT_EQ(s->keyframes[0]->T_c_w.quaternion().coeffs(), first_before.quaternion().coeffs());

  // The outlier observation is gone on both sides; the point lives on with its other views.
  EXPECT_EQ(s->outlier_point->observations.count(s->outlier_keyframe->id), 0u);
  for (map::MapPoint* p : s->outlier_keyframe->points) EXPECT_NE(p, s->outlier_point);
  EXPECT_FALSE(s->outlier_point->bad);
  // The point was not dragged towards the wrong observation: it still projects where it truly is.
  const Vec3 truth = s->true_by_id.at(s->outlier_point->id);
  const Vec2 true_uv = camera.project(s->true_T_c_w[3] * truth);
  EXPECT_LT((camera.project(s->outlier_keyframe->T_c_w * s->outlier_point->position) - true_uv).norm(), 2.0);
  // Clean observations are kept: at most a handful flagged among thousands.
  EXPECT_LT(result.outliers, result.observations / 100 + 2);
}

// A keyframe held where tracking put it (Keyframe::pose_held: local BA would have carried it far,
// or it shares too few points with its map) is not moved by global BA either; the others are.
TEST(GlobalBundleAdjustment, AHeldKeyframeStaysWhereItIs) {
  const PinholeCamera camera = test::tumCamera();
  auto s = makeMapScene(camera, 8, 600, 11);
  SE3 held_before;
  std::vector<SE3> before;
  {
    std::unique_lock lock(s->map.mutex());
    s->keyframes[4]->pose_held = true;
    held_before = s->keyframes[4]->T_c_w;
    for (const map::Keyframe* kf : s->keyframes) before.push_back(kf->T_c_w);
    const std::vector<bool> fixed = map::globalBaFixed(s->keyframes);
    for (size_t k = 0; k < fixed.size(); ++k) EXPECT_EQ(fixed[k], k == 0 || k == 4) << "keyframe " << k;
  }
  ASSERT_GT(translationError(held_before, s->true_T_c_w[4]), 0.005) << "the start is perturbed";
  globalBundleAdjustment(s->map, camera, BundleAdjustmentOptions{});
  std::shared_lock lock(s->map.mutex());
  EXPECT_EQ(s->keyframes[4]->T_c_w.translation(), held_before.translation());
  EXPECT_EQ(s->keyframes[4]->T_c_w.quaternion().coeffs(), held_before.quaternion().coeffs());
  // The free ones move (towards a solution that the held one anchors where it is, 3 cm off).
  for (size_t k : {1u, 2u, 3u, 5u, 6u, 7u})
    EXPECT_GT(translationError(s->keyframes[k]->T_c_w, before[k]), 0.005) << "keyframe " << k;
}

// A keyframe made at a weak pose (few local-map inliers: its own new points could place it) that
// global BA would move more than kMaxWeakKeyframeMoveM relative to its parent is held where it is
// and the problem solved again without moving it; one made at a weak pose 3 cm off moves, as does
// one 15 cm off that was not made at a weak pose.
TEST(GlobalBundleAdjustment, AWeakKeyframeItWouldCarryFarIsHeld) {
  const PinholeCamera camera = test::tumCamera();
  struct Case {
    const char* name;
    bool weak;
    double offset_m;
    bool held;
  };
  for (const Case& c : {Case{"weak, 15 cm off", true, 0.15, true}, Case{"weak, 3 cm off", true, 0.03, false},
                        Case{"not weak, 15 cm off", false, 0.15, false}}) {
    SCOPED_TRACE(c.name);
    auto s = makeMapScene(camera, 8, 600, 11);
    SE3 start;
    {
      std::unique_lock lock(s->map.mutex());
      for (size_t k = 1; k < s->keyframes.size(); ++k) s->keyframes[k]->parent = s->keyframes[k - 1];
      map::Keyframe* kf = s->keyframes[5];
      kf->made_at_weak_pose = c.weak;
      kf->T_c_w = SE3(Mat3::Identity(), Vec3(c.offset_m, 0.0, 0.0)) * s->true_T_c_w[5];  // sideways in its view
      start = kf->T_c_w;
    }
    const GlobalBaResult result = globalBundleAdjustment(s->map, camera, BundleAdjustmentOptions{});
    std::shared_lock lock(s->map.mutex());
    EXPECT_TRUE(result.completed);
    EXPECT_EQ(result.weak_keyframes_held, c.held ? 1u : 0u);
    EXPECT_EQ(s->keyframes[5]->pose_held, c.held);
    if (c.held) {
      EXPECT_EQ(s->keyframes[5]->T_c_w.translation(), start.translation());
    } else {
      EXPECT_LT(translationError(s->keyframes[5]->T_c_w, s->true_T_c_w[5]), 0.005);
    }
    for (size_t k : {1u, 2u, 3u, 4u, 6u, 7u}) EXPECT_FALSE(s->keyframes[k]->pose_held) << "keyframe " << k;
  }
}

// Keyframes 5-7 see their own points and share only `ties` of them with keyframes 0-4 (the
// first keyframes of a map merged into another, tied to its later ones by a few points), and
// start 15 cm beside where those few points put them, everything else consistent. Tied by 5
// points, global BA holds the group where it is (looseGroupsMovedFar: a handful of points,
// possibly a walker's matched by mistake, cannot place it); tied by 60, they join it to the map
// and global BA places it. Made in the map itself (no merge), the group is global BA's to place
// however few points tie it: nothing is held.
TEST(GlobalBundleAdjustment, AGroupMergedInAndTiedByFewPointsIsHeldWhereItIs) {
  const PinholeCamera camera = test::tumCamera();
  struct Case {
    int ties;
    bool merged_in;
  };
  for (const Case c : {Case{5, true}, Case{60, true}, Case{5, false}}) {
    const int ties = c.ties;
    const bool held = ties < kMinGroupTiePoints && c.merged_in;
    SCOPED_TRACE(std::to_string(ties) + " tie points, " + (c.merged_in ? "merged in" : "made in the map"));
    auto s = makeMapScene(camera, 8, 600, 13);
    const SE3 shift(Mat3::Identity(), Vec3(0.15, 0.0, 0.0));  // world-frame move of group B
    const auto inGroupB = [](size_t k) { return k >= 5; };
    std::vector<SE3> start(s->keyframes.size());
    {
      std::unique_lock lock(s->map.mutex());
      if (s->outlier_point != nullptr) map::eraseObservation(s->map, s->outlier_point, s->outlier_keyframe);
      int tied = 0;
      for (size_t p = 0; p < s->points.size(); ++p) {
        map::MapPoint* point = s->points[p];
        if (point == nullptr || point->bad) continue;
        bool seen_a = false, seen_b = false;
        for (size_t k = 0; k < s->keyframes.size(); ++k)
          if (point->observations.count(s->keyframes[k]->id) != 0) (inGroupB(k) ? seen_b : seen_a) = true;
        if (seen_a && seen_b && tied < ties) {
          ++tied;  // a tie: both groups keep seeing it, where group A puts it
          point->position = s->true_points[p];
          continue;
        }
        const bool of_b = p % 2 == 1;  // the others belong to one group only
        for (size_t k = 0; k < s->keyframes.size(); ++k)
          if (inGroupB(k) != of_b) map::eraseObservation(s->map, point, s->keyframes[k]);
        if (!point->bad) point->position = of_b ? Vec3(shift * s->true_points[p]) : s->true_points[p];
      }
      ASSERT_EQ(tied, ties);
      for (size_t k = 0; k < s->keyframes.size(); ++k) {
        s->keyframes[k]->T_c_w = inGroupB(k) ? s->true_T_c_w[k] * shift.inverse() : s->true_T_c_w[k];
        start[k] = s->keyframes[k]->T_c_w;
        if (inGroupB(k) && c.merged_in) s->keyframes[k]->made_in_map = s->keyframes[k]->map_id + 1;
      }
      for (map::Keyframe* k : s->keyframes) map::updateConnections(k);
    }
    const GlobalBaResult result = globalBundleAdjustment(s->map, camera, BundleAdjustmentOptions{});
    std::shared_lock lock(s->map.mutex());
    EXPECT_TRUE(result.completed);
    EXPECT_EQ(result.weak_keyframes_held, 0u);
    EXPECT_EQ(result.loose_groups_held, held ? 1u : 0u);
    for (size_t k = 0; k < s->keyframes.size(); ++k) {
      const double from_start_m = translationError(s->keyframes[k]->T_c_w, start[k]);
      const double from_truth_m = translationError(s->keyframes[k]->T_c_w, s->true_T_c_w[k]);
      if (!inGroupB(k)) {
        EXPECT_LT(from_truth_m, 0.005) << "keyframe " << k;
      } else if (held) {
        EXPECT_LT(from_start_m, 0.005) << "keyframe " << k << " stays where it was";
      } else if (ties >= kMinGroupTiePoints) {
        EXPECT_LT(from_truth_m, 0.005) << "keyframe " << k << " is placed by its ties";
      } else {
        EXPECT_GT(from_start_m, 0.05) << "keyframe " << k << " is moved by global BA";
      }
    }
    EXPECT_EQ(s->keyframes[5]->pose_held, held);
  }
}

// Global BA may shift a whole stretch of a map: a weak keyframe that moves with its parent has not
// been carried off by its own points (measured relative to the parent); local BA, whose window
// keeps the map around fixed, measures the move itself.
TEST(MapBaProblem, AWeakKeyframesMoveIsMeasuredRelativeToItsParentWhereAsked) {
  const PinholeCamera camera = test::tumCamera();
  auto s = makeMapScene(camera, 4, 200, 5);
  std::unique_lock lock(s->map.mutex());
  s->keyframes[2]->parent = s->keyframes[1];
  s->keyframes[3]->parent = s->keyframes[2];
  s->keyframes[2]->made_at_weak_pose = true;
  s->keyframes[3]->made_at_weak_pose = true;
  MapBaProblem problem = buildMapBaProblem(s->keyframes, {true, false, false, false});
  ASSERT_EQ(problem.centres_before.size(), 4u);
  const auto shift = [&](size_t i, const Vec3& by_m) {  // the camera centre moved by by_m
    const SE3 T_w_c = problem.ba_keyframes[i].T_c_w.inverse();
    problem.ba_keyframes[i].T_c_w = SE3(T_w_c.rotation(), T_w_c.translation() + by_m).inverse();
  };
  shift(1, Vec3(0.08, 0, 0));  // keyframe 1 (not weak) and its child 2 move 8 cm together
  shift(2, Vec3(0.08, 0, 0));
  shift(3, Vec3(0.08, 0.0, 0.06));  // keyframe 3: 6 cm beside its parent's move
  const auto ids = [](const std::vector<map::Keyframe*>& kfs) {
    std::vector<uint64_t> out;
    for (const map::Keyframe* k : kfs) out.push_back(k->id);
    return out;
  };
  EXPECT_EQ(ids(weakKeyframesMovedFar(problem, kMaxWeakKeyframeMoveM, true)), std::vector<uint64_t>{s->keyframes[3]->id});
  EXPECT_EQ(ids(weakKeyframesMovedFar(problem, kMaxWeakKeyframeMoveM, false)),
            (std::vector<uint64_t>{s->keyframes[2]->id, s->keyframes[3]->id}));
  s->keyframes[3]->pose_held = true;  // held already: not reported again
  EXPECT_EQ(ids(weakKeyframesMovedFar(problem, kMaxWeakKeyframeMoveM, true)), std::vector<uint64_t>{});
}

// Local BA holds any keyframe it would move more than kMaxKeyframeMoveM, by its own move and by
// its move less its parent's where the parent is in the problem: a parent and child moved
// together is a correction of both, a child left where it was while its parent moved was not
// moved at all. Keyframes made at a weak pose (their own, stricter bar), held ones and fixed ones
// are not reported.
TEST(MapBaProblem, AKeyframeMovedFarByItselfIsReported) {
  const PinholeCamera camera = test::tumCamera();
  auto s = makeMapScene(camera, 7, 200, 5);
  std::unique_lock lock(s->map.mutex());
  for (size_t k = 1; k < 7; ++k) s->keyframes[k]->parent = s->keyframes[k - 1];
  const std::vector<map::Keyframe*> in_problem(s->keyframes.begin() + 1, s->keyframes.end());  // 0 outside
  MapBaProblem problem = buildMapBaProblem(in_problem, {false, false, false, false, false, true});
  const auto shift = [&](size_t i, const Vec3& by_m) {  // problem keyframe i (keyframe i + 1) moved by by_m
    const SE3 T_w_c = problem.ba_keyframes[i].T_c_w.inverse();
    problem.ba_keyframes[i].T_c_w = SE3(T_w_c.rotation(), T_w_c.translation() + by_m).inverse();
  };
  shift(0, Vec3(0.12, 0, 0));     // keyframe 1: 12 cm, its parent outside the problem: far
  shift(1, Vec3(0.20, 0, 0));     // keyframe 2: 20 cm, but 8 cm beyond its parent's 12: not far
  shift(2, Vec3(0.20, 0.11, 0));  // keyframe 3: 11 cm beside its parent's move: far
  // keyframe 4: not moved, while its parent moved 23 cm: not far
  shift(4, Vec3(0.0, 0.3, 0));    // keyframe 5: 30 cm, but made at a weak pose
  s->keyframes[5]->made_at_weak_pose = true;
  shift(5, Vec3(0.0, 0.3, 0));    // keyframe 6: fixed (the solve cannot move it; set for the test)
  const auto ids = [](const std::vector<map::Keyframe*>& kfs) {
    std::vector<uint64_t> out;
    for (const map::Keyframe* k : kfs) out.push_back(k->id);
    return out;
  };
  EXPECT_EQ(ids(keyframesMovedFar(problem, kMaxKeyframeMoveM)),
            (std::vector<uint64_t>{s->keyframes[1]->id, s->keyframes[3]->id}));
  s->keyframes[3]->pose_held = true;  // held already: not reported again
  EXPECT_EQ(ids(keyframesMovedFar(problem, kMaxKeyframeMoveM)), std::vector<uint64_t>{s->keyframes[1]->id});
}

// The builder copies what the map says: fixed keyframes anchor points without contributing
// their own, bad keyframes and points are left out; applying skips what went bad meanwhile.
TEST(MapBaProblem, BuilderAndApplyFollowTheMap) {
  const PinholeCamera camera = test::tumCamera();
  auto s = makeMapScene(camera, 4, 200, 5);
  std::unique_lock lock(s->map.mutex());
  s->map.setKeyframeBad(s->keyframes[2]);
  const std::vector<map::Keyframe*> keyframes = s->keyframes;
  const std::vector<bool> fixed{true, true, false, false};
  MapBaProblem problem = buildMapBaProblem(keyframes, fixed);

  ASSERT_EQ(problem.keyframes.size(), 3u) << "the bad keyframe is skipped";
  EXPECT_TRUE(problem.ba_keyframes[0].fixed);
  EXPECT_TRUE(problem.ba_keyframes[1].fixed);
  EXPECT_FALSE(problem.ba_keyframes[2].fixed);
  EXPECT_EQ(problem.keyframes[2], s->keyframes[3]);
  // Exactly the good points keyframe 3 sees, each with all its observations in the problem.
  size_t seen_by_free = 0;
  for (map::MapPoint* p : s->keyframes[3]->points) seen_by_free += (p != nullptr && !p->bad) ? 1 : 0;
  EXPECT_EQ(problem.points.size(), seen_by_free);
  size_t expected_observations = 0;
  for (map::MapPoint* p : problem.points) expected_observations += p->observations.size();
  EXPECT_EQ(problem.ba_observations.size(), expected_observations);

  // Something moves in the problem; a point culled meanwhile keeps its map position.
  map::MapPoint* culled = problem.points.front();
  const Vec3 culled_position = culled->position;
  for (auto& p : problem.ba_points) p.p_w += Vec3(0.01, 0, 0);
  problem.ba_keyframes[0].T_c_w = SE3(Mat3::Identity(), Vec3(5, 5, 5));  // fixed: must not be applied
  problem.ba_keyframes[2].T_c_w = s->true_T_c_w[3];
  s->map.setPointBad(culled);
  const SE3 fixed_before = s->keyframes[0]->T_c_w;
  applyMapBaResult(s->map, problem);
  EXPECT_EQ(culled->position, culled_position);
  EXPECT_EQ(problem.points.back()->position, problem.ba_points.back().p_w);
  EXPECT_EQ(s->keyframes[0]->T_c_w.translation(), fixed_before.translation());
  EXPECT_EQ(s->keyframes[3]->T_c_w.translation(), s->true_T_c_w[3].translation());
}

}  // namespace
}  // namespace desslam::optim
