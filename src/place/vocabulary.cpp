#include "place/vocabulary.hpp"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <system_error>

#include <spdlog/spdlog.h>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/option_fields.hpp"
#include "feature/descriptor.hpp"

namespace desslam::place {
namespace {

constexpr int kBytes = feature::kDescriptorBytes;
constexpr uint32_t kNoParent = 0xFFFFFFFFu;

// File format, version 1 (all integers little-endian):
//   8 bytes  magic "DESVOCAB"
//   u32      version (1)
//   u32      descriptor bytes (32)
//   u32      branching, u32 depth
//   u32      node count, u32 word count
//   node records in breadth-first order, 40 bytes each:
//            u32 parent (0xFFFFFFFF for the root), 32 bytes descriptor, f32 IDF weight (0 for inner nodes)
//   u64      FNV-1a hash of every byte before it
// Breadth-first order with parents makes the tree implicit: the children of a node are the
// consecutive records naming it as parent; leaves, in record order, are words 0, 1, 2, ...
constexpr char kMagic[8] = {'D', 'E', 'S', 'V', 'O', 'C', 'A', 'B'};
constexpr uint32_t kVersion = 1;
constexpr std::size_t kHeaderBytes = 8 + 6 * 4;
constexpr std::size_t kRecordBytes = 4 + kBytes + 4;

uint64_t fnv1a(const uint8_t* data, std::size_t size) {
  uint64_t hash = 1469598103934665603ull;
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= data[i];
    hash *= 1099511628211ull;
  }
  return hash;
}

void putU32(std::vector<uint8_t>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
}
void putU64(std::vector<uint8_t>& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
}
uint32_t getU32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}
uint64_t getU64(const uint8_t* p) { return uint64_t(getU32(p)) | uint64_t(getU32(p + 4)) << 32; }

void checkDescriptors(const cv::Mat& descriptors, const std::string& what) {
  if (descriptors.empty()) return;
  if (descriptors.type() != CV_8UC1 || descriptors.cols != kBytes)
    throw InputError(what + ": expected N x 32 CV_8U ORB descriptors, got " + std::to_string(descriptors.rows) +
                     " x " + std::to_string(descriptors.cols) + " of type " + cv::typeToString(descriptors.type()));
}

using Descriptor = std::array<uint8_t, kBytes>;

struct Cluster {
  Descriptor center{};
  std::vector<uint32_t> members;
};

// Bitwise majority of the members' descriptors: the binary descriptor closest, in summed
// Hamming distance, to all of them (ties -> 0).
Descriptor majorityCenter(const uint8_t* data, const std::vector<uint32_t>& members) {
  std::array<uint32_t, 8 * kBytes> ones{};
  for (uint32_t m : members) {
    const uint8_t* d = data + std::size_t(m) * kBytes;
    for (int b = 0; b < kBytes; ++b)
      for (int j = 0; j < 8; ++j) ones[8 * b + j] += (d[b] >> j) & 1u;
  }
  Descriptor center{};
  for (int b = 0; b < kBytes; ++b)
    for (int j = 0; j < 8; ++j)
      if (2 * ones[8 * b + j] > members.size()) center[b] |= uint8_t(1u << j);
  return center;
}

// k-means on binary descriptors (Hamming distance, majority-bit centres), k-means++ seeding.
// Returns the non-empty clusters (fewer than k when the data has fewer distinct points).
std::vector<Cluster> clusterDescriptors(const uint8_t* data, const std::vector<uint32_t>& members, int k,
                                        int iterations, std::mt19937& rng) {
  const std::size_t n = members.size();
  auto row = [&](std::size_t i) { return data + std::size_t(members[i]) * kBytes; };
  std::vector<Descriptor> centers;

  if (n <= std::size_t(k)) {
    // Too few to cluster: each distinct descriptor becomes a child of its own.
    std::vector<Cluster> clusters;
    for (std::size_t i = 0; i < n; ++i) {
      auto same = std::find_if(clusters.begin(), clusters.end(), [&](const Cluster& c) {
        return std::memcmp(c.center.data(), row(i), kBytes) == 0;
      });
      if (same != clusters.end()) {
        same->members.push_back(members[i]);
      } else {
        Cluster c;
        std::memcpy(c.center.data(), row(i), kBytes);
        c.members.push_back(members[i]);
        clusters.push_back(std::move(c));
      }
    }
    return clusters;
  }

  // Greedy k-means++: each next centre is drawn with probability proportional to the squared
  // distance to the nearest centre so far; of a few such draws the one that lowers the summed
  // squared distance most is kept (Arthur & Vassilvitskii 2007), so that an unlucky draw does not
  // put two centres into one cluster.
  const int trials = 2 + int(std::log(double(k)));
  std::vector<int> nearest(n, INT_MAX);
  std::vector<int> trial_nearest(n), best_nearest(n);
  {
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);
    Descriptor first;
    std::memcpy(first.data(), row(pick(rng)), kBytes);
    centers.push_back(first);
    for (std::size_t i = 0; i < n; ++i) nearest[i] = feature::descriptorDistance(row(i), first.data());
  }
  while (centers.size() < std::size_t(k)) {
    double total = 0;
    for (std::size_t i = 0; i < n; ++i) total += double(nearest[i]) * nearest[i];
    if (total == 0) break;  // every point coincides with a centre
    std::size_t best = n;
    double best_potential = 0;
    for (int t = 0; t < trials; ++t) {
      const double target = std::uniform_real_distribution<double>(0.0, total)(rng);
      double cumulative = 0;
      std::size_t chosen = n;
      for (std::size_t i = 0; i < n; ++i) {
        if (nearest[i] == 0) continue;
        chosen = i;
        cumulative += double(nearest[i]) * nearest[i];
        if (cumulative >= target) break;
      }
      double potential = 0;
      for (std::size_t i = 0; i < n; ++i) {
        trial_nearest[i] = std::min(nearest[i], feature::descriptorDistance(row(i), row(chosen)));
        potential += double(trial_nearest[i]) * trial_nearest[i];
      }
      if (best == n || potential < best_potential) {
        best = chosen;
        best_potential = potential;
        best_nearest.swap(trial_nearest);
      }
    }
    Descriptor next;
    std::memcpy(next.data(), row(best), kBytes);
    centers.push_back(next);
    nearest.swap(best_nearest);
  }

  // Lloyd iterations until the assignment settles or the iteration budget is spent.
  std::vector<int> assignment(n, -1);
  for (int iteration = 0;; ++iteration) {
    bool changed = false;
    for (std::size_t i = 0; i < n; ++i) {
      int best = 0, best_distance = INT_MAX;
      for (std::size_t c = 0; c < centers.size(); ++c) {
        const int d = feature::descriptorDistance(row(i), centers[c].data());
        if (d < best_distance) {
          best_distance = d;
          best = int(c);
        }
      }
      if (assignment[i] != best) {
        assignment[i] = best;
        changed = true;
      }
    }
    if (!changed || iteration >= iterations) break;
    std::vector<std::vector<uint32_t>> groups(centers.size());
    for (std::size_t i = 0; i < n; ++i) groups[assignment[i]].push_back(members[i]);
    for (std::size_t c = 0; c < centers.size(); ++c)
      if (!groups[c].empty()) centers[c] = majorityCenter(data, groups[c]);  // empty: keep the old one
  }

  std::vector<Cluster> clusters(centers.size());
  for (std::size_t c = 0; c < centers.size(); ++c) clusters[c].center = centers[c];
  for (std::size_t i = 0; i < n; ++i) clusters[assignment[i]].members.push_back(members[i]);
  std::erase_if(clusters, [](const Cluster& c) { return c.members.empty(); });
  return clusters;
}

}  // namespace

void VocabularyOptions::validate() const {
  requireInRange(kSection, "branching", branching, 2, 64);
  requireInRange(kSection, "depth", depth, 1, 8);
  requireInRange(kSection, "kmeans_iterations", kmeans_iterations, 1, 1000);
  requireInRange(kSection, "max_descriptors", max_descriptors, 0, 1e9);
}

Vocabulary Vocabulary::train(const std::vector<cv::Mat>& descriptor_sets, const VocabularyOptions& options) {
  options.validate();
  std::size_t total = 0;
  for (std::size_t s = 0; s < descriptor_sets.size(); ++s) {
    checkDescriptors(descriptor_sets[s], "Vocabulary::train: descriptor set " + std::to_string(s));
    total += std::size_t(descriptor_sets[s].rows);
  }
  if (total == 0) throw InputError("Vocabulary::train: no descriptors given (all training images were empty)");

  // The k-means sample: every descriptor, or an even spread of max_descriptors of them.
  const std::size_t sample_size =
      options.max_descriptors > 0 ? std::min(total, std::size_t(options.max_descriptors)) : total;
  std::vector<uint8_t> data(sample_size * kBytes);
  {
    std::size_t global = 0, taken = 0;
    for (const cv::Mat& set : descriptor_sets) {
      for (int r = 0; r < set.rows && taken < sample_size; ++r, ++global) {
        // Row `global` is taken when floor(global * S / T) steps up there: S rows, evenly spread.
        if (((global + 1) * sample_size) / total > (global * sample_size) / total) {
          std::memcpy(data.data() + taken * kBytes, set.ptr<uint8_t>(r), kBytes);
          ++taken;
        }
      }
    }
    data.resize(taken * kBytes);
  }
  const std::size_t sample_count = data.size() / kBytes;

  // Breadth-first growth: node i is split when it is reached, so children of one node are
  // appended together and end up contiguous.
  std::vector<uint32_t> parents{kNoParent};
  std::vector<Descriptor> centers{Descriptor{}};
  std::vector<int> levels{0};
  std::vector<std::vector<uint32_t>> pending(1);
  pending[0].resize(sample_count);
  for (std::size_t i = 0; i < sample_count; ++i) pending[0][i] = uint32_t(i);

  std::mt19937 rng(options.seed);
  int logged_level = 0;
  for (std::size_t i = 0; i < parents.size(); ++i) {
    const std::vector<uint32_t> members = std::move(pending[i]);
    pending[i] = {};
    if (levels[i] != logged_level) {
      spdlog::debug("vocabulary: splitting level {} of {} ({} nodes so far)", levels[i], options.depth, parents.size());
      logged_level = levels[i];
    }
    if (levels[i] >= options.depth || members.size() <= 1) continue;  // a leaf
    std::vector<Cluster> clusters =
        clusterDescriptors(data.data(), members, options.branching, options.kmeans_iterations, rng);
    if (clusters.size() <= 1 && i != 0) continue;  // identical descriptors: nothing to split
    for (Cluster& c : clusters) {
      parents.push_back(uint32_t(i));
      centers.push_back(c.center);
      levels.push_back(levels[i] + 1);
      pending.push_back(std::move(c.members));
    }
  }

  Vocabulary vocabulary;
  vocabulary.branching_ = options.branching;
  vocabulary.depth_ = options.depth;
  vocabulary.descriptors_.resize(parents.size() * kBytes);
  for (std::size_t i = 0; i < parents.size(); ++i)
    std::memcpy(vocabulary.descriptors_.data() + i * kBytes, centers[i].data(), kBytes);
  vocabulary.linkNodes(parents, "Vocabulary::train");

  // IDF over the training images: ln(N / n_w), n_w = images with at least one descriptor in w.
  vocabulary.weights_.assign(vocabulary.words_.size(), 0.0f);
  std::vector<uint32_t> images_with(vocabulary.words_.size(), 0);
  std::vector<int64_t> last_image(vocabulary.words_.size(), -1);
  int64_t image_count = 0;
  for (const cv::Mat& set : descriptor_sets) {
    if (set.rows == 0) continue;
    for (int r = 0; r < set.rows; ++r) {
      const WordId w = vocabulary.wordOf(set.ptr<uint8_t>(r));
      if (last_image[w] != image_count) {
        last_image[w] = image_count;
        ++images_with[w];
      }
    }
    ++image_count;
  }
  for (std::size_t w = 0; w < images_with.size(); ++w) {
    // A word no training image reaches (rare: k-means centres moved after the last assignment)
    // is treated as the rarest possible.
    const double n_w = std::max<uint32_t>(images_with[w], 1);
    vocabulary.weights_[w] = float(std::log(double(image_count) / n_w));
  }
  spdlog::info("vocabulary: {} words, {} nodes, from {} of {} descriptors in {} images", vocabulary.wordCount(),
               vocabulary.nodeCount(), sample_count, total, image_count);
  return vocabulary;
}

void Vocabulary::linkNodes(const std::vector<uint32_t>& parents, const std::string& source) {
  auto corrupt = [&](const std::string& why) {
    return InputError(source + ": vocabulary tree is corrupt (" + why + "); retrain it with `desslam vocab train`");
  };
  if (parents.empty() || parents[0] != kNoParent) throw corrupt("first node is not the root");
  nodes_.assign(parents.size(), Node{});
  words_.clear();
  for (std::size_t i = 1; i < parents.size(); ++i) {
    const uint32_t p = parents[i];
    if (p >= i) throw corrupt("node " + std::to_string(i) + " has parent " + std::to_string(p) + " not before it");
    if (p < parents[i - 1] && i > 1) throw corrupt("nodes are not in breadth-first order at node " + std::to_string(i));
    Node& parent = nodes_[p];
    if (parent.child_count == 0) parent.first_child = uint32_t(i);
    if (parent.first_child + parent.child_count != i) throw corrupt("children of node " + std::to_string(p) + " are not contiguous");
    ++parent.child_count;
    nodes_[i].parent = p;
    nodes_[i].level = uint8_t(parent.level + 1);
    if (nodes_[i].level > depth_) throw corrupt("node " + std::to_string(i) + " is deeper than the depth " + std::to_string(depth_));
  }
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    if (nodes_[i].child_count == 0) {
      nodes_[i].word = uint32_t(words_.size());
      words_.push_back(NodeId(i));
    }
  }
}

template <class OnNode>
NodeId Vocabulary::descend(const uint8_t* descriptor, OnNode&& on_node) const {
  NodeId node = 0;
  on_node(node);
  while (nodes_[node].child_count > 0) {
    const Node& n = nodes_[node];
    NodeId best = n.first_child;
    int best_distance = INT_MAX;
    for (NodeId c = n.first_child; c < n.first_child + n.child_count; ++c) {
      const int d = feature::descriptorDistance(descriptor, nodeDescriptor(c));
      if (d < best_distance) {
        best_distance = d;
        best = c;
      }
    }
    node = best;
    on_node(node);
  }
  return node;
}

WordId Vocabulary::wordOf(const uint8_t* descriptor) const {
  if (empty()) throw InputError("Vocabulary::wordOf: the vocabulary is empty; load or train one first");
  return nodes_[descend(descriptor, [](NodeId) {})].word;
}

void Vocabulary::transform(const cv::Mat& descriptors, BowVector& bow, FeatureVector& features,
                           int levels_up) const {
  if (empty()) throw InputError("Vocabulary::transform: the vocabulary is empty; load or train one first");
  checkDescriptors(descriptors, "Vocabulary::transform");
  bow.clear();
  features.clear();
  const int target_level = std::clamp(depth_ - levels_up, 0, depth_);
  double sum = 0;
  for (int r = 0; r < descriptors.rows; ++r) {
    NodeId grouping_node = 0;
    const NodeId leaf = descend(descriptors.ptr<uint8_t>(r), [&](NodeId node) {
      if (nodes_[node].level <= target_level) grouping_node = node;
    });
    features[grouping_node].push_back(r);
    const WordId word = nodes_[leaf].word;
    const double weight = weights_[word];
    if (weight > 0) {
      bow[word] += weight;  // the term frequency's 1/N cancels in the L1 normalisation
      sum += weight;
    }
  }
  if (sum > 0)
    for (auto& [word, value] : bow) value /= sum;
}

void Vocabulary::transform(const cv::Mat& descriptors, BowVector& bow) const {
  FeatureVector unused;
  transform(descriptors, bow, unused, 0);
}

double Vocabulary::score(const BowVector& a, const BowVector& b) {
  // For non-negative vectors of unit L1 norm, 1 - 0.5 |a - b|_1 = sum over shared words of
  // min(a_w, b_w): only the shared words need visiting.
  double s = 0;
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (ia->first < ib->first) {
      ++ia;
    } else if (ib->first < ia->first) {
      ++ib;
    } else {
      s += std::min(ia->second, ib->second);
      ++ia;
      ++ib;
    }
  }
  return std::clamp(s, 0.0, 1.0);
}

void Vocabulary::save(const std::filesystem::path& path) const {
  std::vector<uint8_t> out;
  out.reserve(kHeaderBytes + nodes_.size() * kRecordBytes + 8);
  out.insert(out.end(), std::begin(kMagic), std::end(kMagic));
  putU32(out, kVersion);
  putU32(out, kBytes);
  putU32(out, uint32_t(branching_));
  putU32(out, uint32_t(depth_));
  putU32(out, uint32_t(nodes_.size()));
  putU32(out, uint32_t(words_.size()));
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    putU32(out, i == 0 ? kNoParent : nodes_[i].parent);
    out.insert(out.end(), nodeDescriptor(NodeId(i)), nodeDescriptor(NodeId(i)) + kBytes);
    const float weight = nodes_[i].child_count == 0 ? weights_[nodes_[i].word] : 0.0f;
    uint32_t bits;
    std::memcpy(&bits, &weight, 4);
    putU32(out, bits);
  }
  putU64(out, fnv1a(out.data(), out.size()));

  // Written beside the target and renamed, so a failed write never leaves half a vocabulary.
  writeFileAtomically(path, std::string_view(reinterpret_cast<const char*>(out.data()), out.size()), "vocabulary file");
}

Vocabulary Vocabulary::load(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::ifstream file(path, std::ios::binary);
  if (!file)
    throw InputError("cannot open vocabulary file " + name +
                     ": check the path (the default is vocab/desslam_orb_k10l5.bin in the project)");
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  return fromBytes(bytes, name);
}

Vocabulary Vocabulary::fromBytes(const std::vector<uint8_t>& bytes, const std::string& name) {
  if (bytes.size() < sizeof(kMagic) || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0)
    throw InputError(name + " is not a DeS-SLAM vocabulary (bad magic number); train one with `desslam vocab train`");
  if (bytes.size() < kHeaderBytes)
    throw InputError(name + " is truncated (" + std::to_string(bytes.size()) + " bytes, header needs " +
                     std::to_string(kHeaderBytes) + "); copy or train it again");
  const uint8_t* p = bytes.data() + sizeof(kMagic);
  const uint32_t version = getU32(p);
  if (version != kVersion)
    throw InputError(name + ": unsupported vocabulary version " + std::to_string(version) + " (this build reads version " +
                     std::to_string(kVersion) + "); retrain it with `desslam vocab train`");
  const uint32_t descriptor_bytes = getU32(p + 4);
  const uint32_t branching = getU32(p + 8);
  const uint32_t depth = getU32(p + 12);
  const uint32_t node_count = getU32(p + 16);
  const uint32_t word_count = getU32(p + 20);
  if (descriptor_bytes != uint32_t(kBytes) || depth == 0 || depth > 64 || node_count == 0)
    throw InputError(name + ": bad vocabulary header (descriptor bytes " + std::to_string(descriptor_bytes) + ", depth " +
                     std::to_string(depth) + ", nodes " + std::to_string(node_count) + "); retrain it");
  const uint64_t expected = kHeaderBytes + uint64_t(node_count) * kRecordBytes + 8;
  if (bytes.size() < expected)
    throw InputError(name + " is truncated (" + std::to_string(bytes.size()) + " bytes, expected " +
                     std::to_string(expected) + "); copy or train it again");
  if (bytes.size() > expected)
    throw InputError(name + " has " + std::to_string(bytes.size() - expected) +
                     " unexpected trailing bytes; copy or train it again");
  if (getU64(bytes.data() + expected - 8) != fnv1a(bytes.data(), expected - 8))
    throw InputError(name + " fails its checksum (corrupt file); copy or train it again");

  Vocabulary vocabulary;
  vocabulary.branching_ = int(branching);
  vocabulary.depth_ = int(depth);
  vocabulary.descriptors_.resize(std::size_t(node_count) * kBytes);
  std::vector<uint32_t> parents(node_count);
  std::vector<float> node_weights(node_count);
  const uint8_t* record = bytes.data() + kHeaderBytes;
  for (uint32_t i = 0; i < node_count; ++i, record += kRecordBytes) {
    parents[i] = getU32(record);
    std::memcpy(vocabulary.descriptors_.data() + std::size_t(i) * kBytes, record + 4, kBytes);
    const uint32_t bits = getU32(record + 4 + kBytes);
    std::memcpy(&node_weights[i], &bits, 4);
  }
  vocabulary.linkNodes(parents, name);
  if (vocabulary.words_.size() != word_count)
    throw InputError(name + ": header says " + std::to_string(word_count) + " words, the tree has " +
                     std::to_string(vocabulary.words_.size()) + "; retrain it");
  vocabulary.weights_.resize(word_count);
  for (std::size_t w = 0; w < word_count; ++w) vocabulary.weights_[w] = node_weights[vocabulary.words_[w]];
  return vocabulary;
}

}  // namespace desslam::place
