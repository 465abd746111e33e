// The atlas inside map::Map: maps are created, keyframes and points carry their map, a merge
// moves one map into another's world by a given transform and relabels it.
#include <memory>
#include <mutex>

#include <gtest/gtest.h>

#include "map/map.hpp"

namespace desslam::map {
namespace {

std::shared_ptr<const FeatureSet> featuresWithPoints(int n) {
  auto features = std::make_shared<FeatureSet>();
  for (int i = 0; i < n; ++i) {
    features->keypoints.emplace_back(static_cast<float>(10 * i), 5.0f, 31.0f);
    features->uv.emplace_back(10.0 * i, 5.0);
    features->depth.push_back(1.0f);
  }
  features->descriptors = cv::Mat::zeros(n, 32, CV_8U);
  return features;
}

// Points along a line from first_point (in the keyframe's world, moved by T_world_line).
Keyframe* addKeyframe(Map& map, int map_id, const SE3& T_c_w, int points, const Vec3& first_point,
                      const SE3& T_world_line = SE3()) {
  auto features = featuresWithPoints(points);
  Keyframe* kf = map.createKeyframe(0, 0.0, "", features, std::vector<FeatureStatus>(features->size()), cv::Mat(), T_c_w,
                                    map_id);
  for (int i = 0; i < points; ++i) {
    MapPoint* p = map.createPoint(T_world_line * (first_point + Vec3(0.1 * i, 0, 0)), kf);
    addObservation(p, kf, i);
  }
  return kf;
}

TEST(Atlas, KeyframesAndPointsCarryTheirMapAndTheFirstKeyframeIsTheOrigin) {
  Map map;
  std::unique_lock lock(map.mutex());
  const int a = map.createMap(0, 0.0, "first");
  const int b = map.createMap(10, 1.0, "lost");
  EXPECT_NE(a, b);
  Keyframe* a0 = addKeyframe(map, a, SE3(), 3, Vec3(0, 0, 2));
  Keyframe* a1 = addKeyframe(map, a, SE3(), 3, Vec3(0, 0, 2));
  Keyframe* b0 = addKeyframe(map, b, SE3(), 3, Vec3(0, 0, 2));
  EXPECT_TRUE(a0->map_origin);
  EXPECT_FALSE(a1->map_origin);
  EXPECT_TRUE(b0->map_origin);
  EXPECT_EQ(b0->points[0]->map_id, b);
  EXPECT_EQ(map.keyframeCount(a), 2u);
  EXPECT_EQ(map.keyframeCount(b), 1u);
  // An origin is never culled: it holds its map's gauge.
  map.setKeyframeBad(b0);
  EXPECT_FALSE(b0->bad);
  map.setKeyframeBad(a1);
  EXPECT_TRUE(a1->bad);
  EXPECT_EQ(map.keyframeCount(a), 1u);
  const std::vector<bool> fixed = originsFixed(map.keyframes());
  ASSERT_EQ(fixed.size(), 2u);
  EXPECT_TRUE(fixed[0]);
  EXPECT_TRUE(fixed[1]);
}

TEST(Atlas, MergeMovesTheWholeMapByTheTransformAndRelabelsIt) {
  Map map;
  std::unique_lock lock(map.mutex());
  const int a = map.createMap(0, 0.0, "first");
  const int b = map.createMap(10, 1.0, "lost");
  // The same place seen in both maps: B's world is A's moved by T_wB_wA.
  const SE3 T_wB_wA(Quat(Eigen::AngleAxisd(0.9, Vec3(0.3, 1.0, -0.2).normalized())), Vec3(1.0, -2.0, 0.5));
  const SE3 T_c_wA(Quat(Eigen::AngleAxisd(0.2, Vec3::UnitY())), Vec3(0.1, 0.0, 0.3));
  const Vec3 point_wA(0.2, 0.1, 2.0);
  Keyframe* ka = addKeyframe(map, a, T_c_wA, 4, point_wA);
  Keyframe* kb = addKeyframe(map, b, T_c_wA * T_wB_wA.inverse(), 4, point_wA, T_wB_wA);
  Keyframe* kb2 = addKeyframe(map, b, SE3(), 2, Vec3(0, 0, 1));
  const Vec3 kb2_point_wB = kb2->points[0]->position;
  ASSERT_NE(ka->T_c_w.translation(), kb->T_c_w.translation());

  map.mergeMap(b, a, T_wB_wA.inverse(), 1.5);
  EXPECT_EQ(map.liveMap(b), a);
  EXPECT_EQ(map.mergeCount(), 1u);
  EXPECT_EQ(kb->map_id, a);
  EXPECT_EQ(kb2->map_id, a);
  EXPECT_FALSE(kb->map_origin) << "after a merge only the surviving map's origin holds the gauge";
  EXPECT_EQ(kb->made_in_map, b) << "where a keyframe was made survives the merge";
  EXPECT_EQ(ka->made_in_map, a);
  EXPECT_TRUE(ka->map_origin);
  EXPECT_EQ(map.keyframeCount(a), 3u);
  EXPECT_EQ(map.keyframeCount(b), 0u);
  // Same place, same pose and point now.
  EXPECT_LT((kb->T_c_w.translation() - ka->T_c_w.translation()).norm(), 1e-9);
  EXPECT_LT((kb->T_c_w.inverse() * ka->T_c_w).rotationAngle(), 1e-9);
  for (int i = 0; i < 4; ++i) {
    EXPECT_LT((kb->points[i]->position - ka->points[i]->position).norm(), 1e-9);
    EXPECT_EQ(kb->points[i]->map_id, a);
  }
  EXPECT_LT((kb2->points[0]->position - T_wB_wA.inverse() * kb2_point_wB).norm(), 1e-9);
  // The record says what happened.
  const std::vector<MapRecord> records = map.mapRecords();
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[1].merged_into, a);
  EXPECT_DOUBLE_EQ(records[1].merged_at, 1.5);
  EXPECT_LT((records[1].T_into_this * T_wB_wA).log().norm(), 1e-9);
  // A keyframe created for the merged map lands in the live one.
  Keyframe* late = addKeyframe(map, b, SE3(), 1, Vec3(0, 0, 1));
  EXPECT_EQ(late->map_id, a);
  EXPECT_EQ(late->made_in_map, a);
  EXPECT_FALSE(late->map_origin);
}

}  // namespace
}  // namespace desslam::map
