// Bag-of-words data types: what a vocabulary makes of one image's descriptors.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

namespace desslam::place {

// Index of a leaf (visual word) of the vocabulary, 0..wordCount()-1.
using WordId = uint32_t;
// Index of any node of the vocabulary tree (root = 0), 0..nodeCount()-1.
using NodeId = uint32_t;

// Word -> TF-IDF weight of one image, L1-normalised (weights sum to 1). Ordered by word, so two
// vectors are compared by one merge pass.
using BowVector = std::map<WordId, double>;

// Direct index of one image: tree node (at a chosen level above the leaves) -> indices of the
// image's descriptors (rows) that fall under that node. Descriptor matching between two images
// only compares descriptors that share a node, instead of all pairs.
using FeatureVector = std::map<NodeId, std::vector<int>>;

// Calls fn(node, rows_a, rows_b) for every node present in both feature vectors, in node order.
// Both vectors must come from the same vocabulary and the same `levels_up`.
template <class Fn>
void forEachSharedNode(const FeatureVector& a, const FeatureVector& b, Fn&& fn) {
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (ia->first < ib->first) {
      ia = a.lower_bound(ib->first);
    } else if (ib->first < ia->first) {
      ib = b.lower_bound(ia->first);
    } else {
      fn(ia->first, ia->second, ib->second);
      ++ia;
      ++ib;
    }
  }
}

}  // namespace desslam::place
