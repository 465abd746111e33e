// Visual vocabulary for place recognition: a tree of binary ORB descriptors built by
// hierarchical k-means (Nister & Stewenius 2006; binary variant as in Galvez-Lopez & Tardos 2012),
// with TF-IDF word weights. It turns the descriptors of one image into a bag-of-words vector
// (compared between images by an L1 score) and a feature vector (direct index for matching).
//
// Thread safety: a Vocabulary does not change after train()/load(); its const methods may be
// called from several threads at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "place/bow_types.hpp"

namespace desslam::place {

struct VocabularyOptions {
  int branching = 10;            // k: children per node
  int depth = 5;                 // L: levels below the root; up to k^L words
  int kmeans_iterations = 10;    // Lloyd iterations per node (stops early when assignments settle)
  unsigned seed = 1;             // k-means++ seeding; same inputs + seed => same vocabulary
  // k-means sees at most this many descriptors (evenly spread over the input, 0 = all): the tree
  // shape needs far fewer than a whole dataset. IDF weights are counted on all given descriptors.
  int max_descriptors = 300000;

  static constexpr const char* kSection = "vocabulary";
  template <class V> void fields(V& v) {
    v("branching", branching); v("depth", depth); v("kmeans_iterations", kmeans_iterations);
    v("seed", seed); v("max_descriptors", max_descriptors);
  }
  // Throws ConfigError naming vocabulary.<key>: branching 2..64, depth 1..8, iterations >= 1,
  // max_descriptors >= 0.
  void validate() const;
};

class Vocabulary {
 public:
  // An empty vocabulary (no words); transform() of it throws. Use train() or load().
  Vocabulary() = default;

  // descriptor_sets: one N x 32 CV_8U matrix of ORB descriptors per training image (the image
  // count is the "document" count of the IDF weights: idf(w) = ln(images / images containing w)).
  // Throws InputError when a set has the wrong type/width or there are no descriptors at all;
  // ConfigError for bad options.
  static Vocabulary train(const std::vector<cv::Mat>& descriptor_sets, const VocabularyOptions& options);

  // Binary file (format in vocabulary.cpp): magic, version, shape, one record per node, checksum.
  // save() throws InputError naming the file when it cannot be written; load() when it cannot be
  // read, or has a bad magic number, unknown version, is truncated or fails its checksum.
  void save(const std::filesystem::path& path) const;
  static Vocabulary load(const std::filesystem::path& path);
  // The same from a file's bytes in memory; `name` names it in messages.
  static Vocabulary fromBytes(const std::vector<uint8_t>& bytes, const std::string& name);

  // bow: word -> tf-idf weight, L1-normalised (words of zero weight are left out; empty when
  // `descriptors` is empty). features: for each descriptor row i, the node on its path at
  // `levels_up` levels above the deepest level (depth - levels_up from the root, clamped to
  // [0, depth]; a leaf that ends higher stands for itself) -> rows. levels_up = 0 groups by word.
  // For matching between keyframes, group a few levels below the root, e.g. levels_up =
  // depth() - 2 (up to k^2 = 100 groups for k = 10); smaller groups miss more true matches.
  // descriptors: N x 32 CV_8U (throws InputError otherwise, or when the vocabulary is empty).
  void transform(const cv::Mat& descriptors, BowVector& bow, FeatureVector& features, int levels_up) const;
  void transform(const cv::Mat& descriptors, BowVector& bow) const;

  // The word (leaf) a single 32-byte descriptor falls into.
  WordId wordOf(const uint8_t* descriptor) const;

  // L1 score of two L1-normalised BoW vectors: 1 - 0.5 * |a - b|_1, in [0, 1]; 1 = same words
  // in the same proportions, 0 = no word in common.
  static double score(const BowVector& a, const BowVector& b);

  bool empty() const { return words_.empty(); }
  std::size_t wordCount() const { return words_.size(); }
  std::size_t nodeCount() const { return nodes_.size(); }
  int branching() const { return branching_; }
  int depth() const { return depth_; }
  // IDF weight of a word (0 when every training image has it).
  double wordWeight(WordId word) const { return weights_.at(word); }
  // Level of a node: 0 = root, leaves at most depth().
  int nodeLevel(NodeId node) const { return nodes_.at(node).level; }

 private:
  struct Node {
    uint32_t parent = 0;
    uint32_t first_child = 0;
    uint32_t child_count = 0;  // 0 => leaf
    uint32_t word = 0;         // for leaves
    uint8_t level = 0;
  };

  const uint8_t* nodeDescriptor(NodeId node) const { return descriptors_.data() + std::size_t(node) * 32; }
  // Walks from the root to the leaf nearest (Hamming) at each level; calls on_node(node) for
  // every node on the way, the root included.
  template <class OnNode> NodeId descend(const uint8_t* descriptor, OnNode&& on_node) const;
  // Fills child ranges, leaf word ids and levels from parents_ (nodes in breadth-first order).
  // Throws InputError mentioning `source` when the parent list is not a valid breadth-first tree.
  void linkNodes(const std::vector<uint32_t>& parents, const std::string& source);

  int branching_ = 0;
  int depth_ = 0;
  std::vector<Node> nodes_;            // breadth-first: children of a node are contiguous
  std::vector<uint8_t> descriptors_;   // 32 bytes per node (root: zeros)
  std::vector<NodeId> words_;          // word id -> leaf node
  std::vector<float> weights_;         // word id -> idf
};

}  // namespace desslam::place
