#include "tracking/relocaliser.hpp"

#include <algorithm>
#include <mutex>
#include <shared_mutex>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "core/error.hpp"
#include "matching/matcher.hpp"
#include "tracking/frame_pose.hpp"

namespace desslam::tracking {

namespace {
constexpr int kCovisiblesPerGroup = 10;       // neighbours summed into a candidate's group score
constexpr double kMinSharedWordsRatio = 0.8;  // candidates share at least this share of the best's words
constexpr int kCovisiblesSearched = 10;       // keyframes whose points the guided search projects
constexpr double kGuidedSearchRatio = 0.9;    // the pose is known: a looser ratio test suffices
constexpr double kNarrowSearchFactor = 0.3;   // second guided search, after re-optimisation
constexpr int kMinPointsForPnp = 6;
}  // namespace

PnpResult solvePnpRansac(const std::vector<Vec3>& points_w, const std::vector<Vec2>& uv, const PinholeCamera& camera,
                         const RelocalisationOptions& options) {
  if (points_w.size() != uv.size())
    throw InputError("solvePnpRansac: " + std::to_string(points_w.size()) + " points but " +
                     std::to_string(uv.size()) + " pixels; pass one pixel per point");
  PnpResult result;
  if (static_cast<int>(points_w.size()) < std::max(kMinPointsForPnp, options.min_pnp_inliers)) return result;
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  object.reserve(points_w.size());
  image.reserve(uv.size());
  for (size_t i = 0; i < points_w.size(); ++i) {
    object.emplace_back(points_w[i].x(), points_w[i].y(), points_w[i].z());
    image.emplace_back(uv[i].x(), uv[i].y());
  }
  // The pixels are undistorted already: intrinsics only.
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  try {
    const bool ok = cv::solvePnPRansac(object, image, camera.K(), cv::noArray(), rvec, tvec, false,
                                       options.ransac_iterations, static_cast<float>(options.ransac_reprojection_px),
                                       options.ransac_confidence, inliers, cv::SOLVEPNP_ITERATIVE);
    if (!ok) return result;
  } catch (const cv::Exception&) {
    return result;  // degenerate configurations make OpenCV throw; that is a failed attempt here
  }
  cv::Mat R_cv;
  cv::Rodrigues(rvec, R_cv);
  Mat3 R;
  cv::cv2eigen(R_cv, R);
  const Vec3 t(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  if (!R.allFinite() || !t.allFinite()) return result;
  result.T_c_w = SE3(R, t);
  result.inliers = std::move(inliers);
  result.ok = static_cast<int>(result.inliers.size()) >= options.min_pnp_inliers;
  return result;
}

Relocaliser::Relocaliser(const RelocalisationOptions& options, const PinholeCamera& camera, map::Map& map,
                         const place::KeyframeDatabase& database, double bf)
    : options_(options), camera_(camera), map_(map), database_(database), bf_(bf) {
  options_.validate();
}

RelocalisationResult Relocaliser::relocalise(map::Frame& frame, int only_map) const {
  RelocalisationResult result;
  frame.clearMatches();
  if (database_.size() == 0 || frame.features == nullptr || frame.features->size() == 0) return result;
  const place::BowEncoding encoding = database_.encode(*frame.features, frame.status);
  if (encoding.bow.empty()) return result;
  const SE3 prior_T_c_w = frame.T_c_w;

  for (map::Keyframe* kf : candidates(encoding.bow, only_map)) {
    ++result.candidates;
    const auto matches = matchByNodes(frame, encoding.features, kf);
    result.best_matches = std::max(result.best_matches, static_cast<int>(matches.size()));
    if (static_cast<int>(matches.size()) < options_.min_matches) continue;

    std::vector<Vec3> points_w;
    std::vector<Vec2> uv;
    std::vector<std::pair<int, map::MapPoint*>> used;
    {
      std::shared_lock lock(map_.mutex());
      for (const auto& [feature, point] : matches) {
        if (point->bad) continue;
        points_w.push_back(point->position);
        uv.push_back(frame.features->uv[static_cast<size_t>(feature)]);
        used.emplace_back(feature, point);
      }
    }
    const PnpResult pnp = solvePnpRansac(points_w, uv, camera_, options_);
    result.best_pnp_inliers = std::max(result.best_pnp_inliers, static_cast<int>(pnp.inliers.size()));
    if (!pnp.ok) continue;

    frame.clearMatches();
    for (int k : pnp.inliers) frame.matches[static_cast<size_t>(used[static_cast<size_t>(k)].first)].point =
        used[static_cast<size_t>(k)].second;
    frame.T_c_w = pnp.T_c_w;
    int inliers = optimizePose(frame);
    if (inliers >= options_.min_pnp_inliers && inliers < options_.min_inliers) {
      // Few matches from one keyframe's words: look for the neighbourhood's points where the
      // pose says they are, then refine; once more in a narrower window if it got close.
      if (searchCovisiblePoints(frame, kf, options_.search_radius_px) > 0) inliers = optimizePose(frame);
      if (inliers > options_.min_inliers / 2 && inliers < options_.min_inliers &&
          searchCovisiblePoints(frame, kf, kNarrowSearchFactor * options_.search_radius_px) > 0)
        inliers = optimizePose(frame);
    }
    result.best_inliers = std::max(result.best_inliers, inliers);
    if (inliers >= options_.min_inliers) {
      result.success = true;
      result.keyframe = kf;
      result.inliers = inliers;
      return result;
    }
    frame.clearMatches();
    frame.T_c_w = prior_T_c_w;
  }
  return result;
}

std::vector<map::Keyframe*> Relocaliser::candidates(const place::BowVector& bow, int only_map) const {
  std::vector<place::KeyframeCandidate> results = database_.query(bow);
  if (only_map >= 0) {
    // Before the bars relative to the best candidate: another map may see the place best.
    std::shared_lock lock(map_.mutex());
    std::erase_if(results, [&](const place::KeyframeCandidate& r) { return r.keyframe->map_id != only_map; });
  }
  if (results.empty()) return {};
  int max_shared = 0;
  for (const auto& r : results) max_shared = std::max(max_shared, r.shared_words);
  const int min_shared = static_cast<int>(kMinSharedWordsRatio * max_shared);
  std::erase_if(results, [&](const place::KeyframeCandidate& r) { return r.shared_words < min_shared; });

  struct Group {
    double score;
    map::Keyframe* best;
  };
  std::vector<Group> groups;
  {
    std::shared_lock lock(map_.mutex());
    std::unordered_map<uint64_t, double> score_of;
    for (const auto& r : results) score_of[r.keyframe->id] = r.score;
    for (const auto& r : results) {
      if (r.keyframe->bad) continue;
      Group group{r.score, r.keyframe};
      if (options_.group_covisible) {
        // A place seen by several keyframes that all score well beats a single lucky keyframe.
        double best_score = r.score;
        for (map::Keyframe* neighbour : map::bestCovisibles(r.keyframe, kCovisiblesPerGroup)) {
          auto it = score_of.find(neighbour->id);
          if (it == score_of.end() || neighbour->bad) continue;
          group.score += it->second;
          if (it->second > best_score) {
            best_score = it->second;
            group.best = neighbour;
          }
        }
      }
      groups.push_back(group);
    }
  }
  if (groups.empty()) return {};
  std::sort(groups.begin(), groups.end(), [](const Group& a, const Group& b) {
    return a.score != b.score ? a.score > b.score : a.best->id < b.best->id;
  });
  const double min_score = options_.group_score_ratio * groups.front().score;
  std::vector<map::Keyframe*> chosen;
  std::unordered_set<uint64_t> seen;
  for (const Group& g : groups) {
    if (g.score < min_score || static_cast<int>(chosen.size()) >= options_.max_candidates) break;
    if (seen.insert(g.best->id).second) chosen.push_back(g.best);
  }
  return chosen;
}

std::vector<std::pair<int, map::MapPoint*>> Relocaliser::matchByNodes(const map::Frame& frame,
                                                                      const place::FeatureVector& frame_nodes,
                                                                      map::Keyframe* keyframe) const {
  const std::optional<place::FeatureVector> keyframe_nodes = database_.featureVector(keyframe->id);
  if (!keyframe_nodes) return {};
  std::vector<map::MapPoint*> points;
  {
    std::shared_lock lock(map_.mutex());
    if (keyframe->bad) return {};
    points = keyframe->points;
    for (map::MapPoint*& p : points)
      if (p != nullptr && p->bad) p = nullptr;
  }
  std::vector<std::pair<int, int>> pairs;  // (keyframe feature, frame feature)
  std::vector<int> kf_rows, frame_rows;
  place::forEachSharedNode(*keyframe_nodes, frame_nodes,
                          [&](place::NodeId, const std::vector<int>& kf_members, const std::vector<int>& frame_members) {
                            kf_rows.clear();
                            frame_rows.clear();
                            for (int i : kf_members)
                              if (points[static_cast<size_t>(i)] != nullptr) kf_rows.push_back(i);
                            for (int i : frame_members)
                              if (frame.usable(static_cast<size_t>(i))) frame_rows.push_back(i);
                            if (kf_rows.empty() || frame_rows.empty()) return;
                            // Each frame feature lives in one node, so matches of different nodes
                            // never share a frame feature: per-node uniqueness is global.
                            const auto node_pairs = matching::matchDescriptors(
                                *keyframe->features, kf_rows, *frame.features, frame_rows,
                                options_.max_descriptor_distance, options_.match_ratio, false);
                            pairs.insert(pairs.end(), node_pairs.begin(), node_pairs.end());
                          });
  // Rotation consistency over all nodes at once (per node there are too few matches to vote).
  std::vector<float> angle_differences;
  angle_differences.reserve(pairs.size());
  for (auto [ikf, iframe] : pairs)
    angle_differences.push_back(keyframe->features->keypoints[static_cast<size_t>(ikf)].angle -
                                frame.features->keypoints[static_cast<size_t>(iframe)].angle);
  const std::vector<bool> keep = matching::orientationConsistent(angle_differences);
  std::vector<std::pair<int, map::MapPoint*>> matches;
  for (size_t k = 0; k < pairs.size(); ++k)
    if (keep[k]) matches.emplace_back(pairs[k].second, points[static_cast<size_t>(pairs[k].first)]);
  return matches;
}

int Relocaliser::searchCovisiblePoints(map::Frame& frame, map::Keyframe* keyframe, double radius_px) const {
  const map::FeatureSet& features = *frame.features;
  const auto& pyramid = *features.pyramid;
  const int top_level = pyramid.levels() - 1;
  const Vec3 center = frame.T_c_w.inverse().translation();
  MatcherOptions matcher;  // its own ratio; the matching section is for tracking, mapping and loops
  matcher.ratio = kGuidedSearchRatio;
  std::shared_lock lock(map_.mutex());
  std::unordered_set<uint64_t> taken;
  for (const map::FeatureMatch& m : frame.matches)
    if (m.point != nullptr) taken.insert(m.point->id);
  std::vector<map::Keyframe*> keyframes{keyframe};
  for (map::Keyframe* kf : map::bestCovisibles(keyframe, kCovisiblesSearched)) keyframes.push_back(kf);
  std::vector<matching::ProjectionCandidate> candidates;
  for (map::Keyframe* kf : keyframes) {
    if (kf->bad) continue;
    for (map::MapPoint* p : kf->points) {
      if (p == nullptr || p->bad || p->descriptor.empty() || !taken.insert(p->id).second) continue;
      const Vec3 p_c = frame.T_c_w * p->position;
      if (p_c.z() <= 0.05 || !camera_.inImage(camera_.project(p_c))) continue;
      const double distance = (p->position - center).norm();
      if (distance < 0.8 * p->min_distance || distance > 1.2 * p->max_distance) continue;
      const int level = map::predictLevel(p, distance, pyramid);
      matching::ProjectionCandidate c;
      c.p_w = p->position;
      c.point = p;
      c.descriptor = p->descriptor.ptr<uint8_t>();
      c.min_level = std::max(0, level - 1);
      c.max_level = std::min(top_level, level + 1);
      c.radius = radius_px * pyramid.scale[static_cast<size_t>(level)];
      candidates.push_back(c);
    }
  }
  // The search reads the map points' descriptors: keep the shared lock.
  return matching::searchByProjection(frame, camera_, candidates, matcher);
}

int Relocaliser::optimizePose(map::Frame& frame) const { return optimizeFramePose(frame, map_, camera_, bf_); }

}  // namespace desslam::tracking
