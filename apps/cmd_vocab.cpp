// `desslam vocab train <image_list>... --out <file>`: trains a bag-of-words vocabulary on ORB
// descriptors of the listed images. `desslam vocab check <sequence-dir> --vocab <file>`: the
// place-recognition check of the vocabulary test on a whole TUM-layout sequence. The work is in
// desslam_loop; this file reads images and wires arguments.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "commands.hpp"
#include "core/error.hpp"
#include "eval/association.hpp"
#include "feature/orb_extractor.hpp"
#include "feature/orb_options.hpp"
#include "io/data_lines.hpp"
#include "io/tum_dataset.hpp"
#include "place/bow_database.hpp"
#include "place/vocabulary.hpp"

namespace desslam::app {
namespace {

namespace fs = std::filesystem;

struct TrainArgs {
  std::vector<std::string> image_lists;
  std::string out;
  int branching = 10;
  int depth = 5;
  int iterations = 10;
  unsigned seed = 1;
  int every = 1;
  int max_images = 0;
  int features_per_image = 1000;
  int max_descriptors = 300000;
};

struct CheckArgs {
  std::string sequence;
  std::string vocab;
  int every = 5;
  double max_translation = 0.3;
  double max_rotation_deg = 30.0;
  bool verbose = false;
};

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Image paths of a list file: one path per line, or TUM "timestamp path" lines; '#' comments.
// Relative paths are relative to the list's folder (as in TUM's rgb.txt).
std::vector<fs::path> readImageList(const fs::path& list) {
  std::ifstream file(list);
  if (!file) throw InputError("cannot open image list " + list.string() + ": check the path");
  std::vector<fs::path> paths;
  io::forEachDataLine(file, [&](const std::string& line, int) {
    std::istringstream fields(line);
    std::string a, b;
    fields >> a >> b;
    std::string path_text = a;
    if (!b.empty()) {
      char* end = nullptr;
      std::strtod(a.c_str(), &end);
      if (end != nullptr && *end == '\0') path_text = b;  // "timestamp path"
    }
    fs::path path(path_text);
    if (path.is_relative()) path = list.parent_path() / path;
    paths.push_back(path);
  });
  if (paths.empty()) throw InputError("image list " + list.string() + " names no images");
  return paths;
}

// ORB descriptors of each image (gray), on all cores; extract() is reentrant.
std::vector<cv::Mat> extractDescriptors(const std::vector<fs::path>& images, const OrbOptions& orb) {
  const feature::OrbExtractor extractor(orb);
  std::vector<cv::Mat> sets(images.size());
  std::vector<std::string> errors(images.size());
  std::atomic<std::size_t> next{0}, done{0};
  auto work = [&] {
    for (std::size_t i = next++; i < images.size(); i = next++) {
      const cv::Mat gray = cv::imread(images[i].string(), cv::IMREAD_GRAYSCALE);
      if (gray.empty()) {
        errors[i] = "cannot read image " + images[i].string() + " (missing or not an image)";
      } else {
        std::vector<cv::KeyPoint> keypoints;
        extractor.extract(gray, keypoints, sets[i]);
      }
      const std::size_t count = ++done;
      if (count % 25 == 0 || count == images.size())
        std::cerr << "\rextracting ORB descriptors: " << count << "/" << images.size() << std::flush;
    }
  };
  const unsigned workers = std::max(1u, std::min(4u, std::thread::hardware_concurrency()));
  std::vector<std::thread> threads;
  for (unsigned t = 0; t < workers; ++t) threads.emplace_back(work);
  for (std::thread& t : threads) t.join();
  std::cerr << "\n";
  for (const std::string& e : errors)
    if (!e.empty()) throw InputError(e);
  return sets;
}

void runTrain(const TrainArgs& args) {
  place::VocabularyOptions options;
  options.branching = args.branching;
  options.depth = args.depth;
  options.kmeans_iterations = args.iterations;
  options.seed = args.seed;
  options.max_descriptors = args.max_descriptors;
  options.validate();
  if (args.every < 1) throw ConfigError("--every must be >= 1");

  std::vector<fs::path> images;
  for (const std::string& list : args.image_lists) {
    const std::vector<fs::path> listed = readImageList(list);
    for (std::size_t i = 0; i < listed.size(); i += std::size_t(args.every)) images.push_back(listed[i]);
  }
  if (args.max_images > 0 && images.size() > std::size_t(args.max_images)) {
    std::vector<fs::path> spread;  // evenly over all lists
    for (int i = 0; i < args.max_images; ++i) spread.push_back(images[std::size_t(i) * images.size() / args.max_images]);
    images = std::move(spread);
  }
  std::cout << "training on " << images.size() << " images\n";

  OrbOptions orb;
  orb.num_features = args.features_per_image;
  const auto start = std::chrono::steady_clock::now();
  const std::vector<cv::Mat> sets = extractDescriptors(images, orb);
  const double extraction_s = secondsSince(start);

  const auto train_start = std::chrono::steady_clock::now();
  const place::Vocabulary vocabulary = place::Vocabulary::train(sets, options);
  const double training_s = secondsSince(train_start);
  vocabulary.save(args.out);
  std::size_t descriptors = 0;
  for (const cv::Mat& s : sets) descriptors += std::size_t(s.rows);
  std::cout << "vocabulary: k=" << vocabulary.branching() << " L=" << vocabulary.depth() << ", "
            << vocabulary.wordCount() << " words, " << vocabulary.nodeCount() << " nodes\n"
            << "descriptors: " << descriptors << " from " << images.size() << " images (k-means on at most "
            << args.max_descriptors << ")\n"
            << "time: extraction " << extraction_s << " s, training " << training_s << " s\n"
            << "written " << args.out << " (" << fs::file_size(args.out) << " bytes)\n";
}

void runCheck(const CheckArgs& args) {
  if (args.every < 1) throw ConfigError("--every must be >= 1");
  const place::Vocabulary vocabulary = place::Vocabulary::load(args.vocab);
  const io::TumSequence sequence = io::TumSequence::open(args.sequence);
  if (!sequence.groundTruth()) {
    if (!sequence.groundTruthProblem().empty())
      throw InputError(sequence.groundTruthProblem() + " (vocab check needs the ground truth)");
    throw InputError(args.sequence + " has no groundtruth.txt; the check needs it");
  }

  // Keyframes: every n-th frame that has a ground-truth pose within 0.02 s.
  Trajectory stamps;
  for (std::size_t i = 0; i < sequence.size(); i += std::size_t(args.every))
    stamps.push_back({sequence.record(i).rgb_timestamp, SE3()});
  const Trajectory& gt = *sequence.groundTruth();
  struct Keyframe {
    fs::path image;
    SE3 T_w_c;
    place::BowVector bow;
  };
  std::vector<Keyframe> keyframes;
  for (const eval::Match& m : eval::associate(gt, stamps, 0.02))
    keyframes.push_back({sequence.record(m.est_index * std::size_t(args.every)).rgb_path, gt[m.gt_index].T_w_c, {}});
  if (keyframes.size() < 2) throw InputError(args.sequence + ": fewer than two keyframes with ground truth");

  std::vector<fs::path> images;
  for (const Keyframe& k : keyframes) images.push_back(k.image);
  const std::vector<cv::Mat> sets = extractDescriptors(images, OrbOptions{});
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < keyframes.size(); ++i) vocabulary.transform(sets[i], keyframes[i].bow);
  const double transform_ms = 1000.0 * secondsSince(start) / double(keyframes.size());

  const std::size_t half = keyframes.size() / 2;
  place::BowDatabase database(vocabulary);
  for (std::size_t i = 0; i < half; ++i) database.add(i, keyframes[i].bow);
  auto near = [&](std::size_t a, std::size_t b) {
    const SE3 T_a_b = keyframes[a].T_w_c.inverse() * keyframes[b].T_w_c;
    return T_a_b.translation().norm() <= args.max_translation &&
           T_a_b.rotationAngle() * 180.0 / M_PI <= args.max_rotation_deg;
  };
  int good = 0, queries = 0;
  int reachable = 0;  // queries with at least one database keyframe near them (the best possible)
  double chance = 0;  // share of database keyframes near each query: what a random pick would score
  for (std::size_t q = half; q < keyframes.size(); ++q) {
    int near_count = 0;
    for (std::size_t d = 0; d < half; ++d) near_count += near(q, d) ? 1 : 0;
    chance += double(near_count) / double(std::max<std::size_t>(half, 1));
    reachable += near_count > 0 ? 1 : 0;
    const auto results = database.query(keyframes[q].bow, 1);
    ++queries;
    if (results.empty()) {
      if (args.verbose) std::cout << "query " << q << ": no candidate\n";
      continue;
    }
    const SE3 T_q_c = keyframes[q].T_w_c.inverse() * keyframes[results[0].id].T_w_c;
    const double dt = T_q_c.translation().norm();
    const double dr = T_q_c.rotationAngle() * 180.0 / M_PI;
    const bool ok = near(q, results[0].id);
    good += ok ? 1 : 0;
    if (args.verbose)
      std::cout << "query " << q << " -> " << results[0].id << " score " << results[0].score << ": " << dt << " m, "
                << dr << " deg" << (ok ? "" : "  (wrong place)") << "\n";
  }
  std::cout << "vocabulary " << args.vocab << ": " << vocabulary.wordCount() << " words; transform "
            << transform_ms << " ms per image\n"
            << "retrieval on " << args.sequence << " (every " << args.every << "th frame, " << half
            << " database keyframes, " << queries << " queries): " << good << "/" << queries << " = "
            << 100.0 * good / std::max(queries, 1) << " % within " << args.max_translation << " m and "
            << args.max_rotation_deg << " deg (a random database keyframe: " << 100.0 * chance / std::max(queries, 1)
            << " %; queries with a near keyframe at all: "
            << reachable << ")\n";
}

}  // namespace

void registerVocabCommand(CLI::App& app) {
  CLI::App* vocab = app.add_subcommand("vocab", "Bag-of-words vocabulary for place recognition: train, check");
  vocab->require_subcommand(1);

  auto train = std::make_shared<TrainArgs>();
  CLI::App* cmd = vocab->add_subcommand(
      "train", "Train a vocabulary (hierarchical k-means on ORB descriptors, TF-IDF weights)");
  cmd->add_option("image_list", train->image_lists,
                  "Text file(s) listing images: one path per line, or a TUM rgb.txt (timestamp path); "
                  "relative paths are relative to the list's folder")
      ->required();
  cmd->add_option("--out", train->out, "Vocabulary file to write")->required();
  cmd->add_option("--branching", train->branching, "Children per tree node (k)")->check(CLI::Range(2, 64))->capture_default_str();
  cmd->add_option("--depth", train->depth, "Tree levels (L); up to k^L words")->check(CLI::Range(1, 8))->capture_default_str();
  cmd->add_option("--iterations", train->iterations, "k-means iterations per node")->check(CLI::Range(1, 1000))->capture_default_str();
  cmd->add_option("--seed", train->seed, "Seed of the k-means++ initialisation")->capture_default_str();
  cmd->add_option("--every", train->every, "Use every n-th image of each list")->check(CLI::Range(1, 1000000))->capture_default_str();
  cmd->add_option("--max-images", train->max_images, "At most this many images, evenly spread (0 = all)")
      ->check(CLI::Range(0, 100000000))
      ->capture_default_str();
  cmd->add_option("--features-per-image", train->features_per_image, "ORB features extracted per image")
      ->check(CLI::Range(50, 20000))
      ->capture_default_str();
  cmd->add_option("--max-descriptors", train->max_descriptors,
                  "k-means runs on at most this many descriptors, evenly spread (0 = all)")
      ->check(CLI::Range(0, 2000000000))
      ->capture_default_str();
  cmd->callback([train] { runTrain(*train); });

  auto check = std::make_shared<CheckArgs>();
  CLI::App* chk = vocab->add_subcommand(
      "check", "Place-recognition check on a TUM-layout sequence with ground truth: every n-th frame is a "
               "keyframe, the first half the database, the second half queries; a query succeeds when its best "
               "candidate is near it in ground truth");
  chk->add_option("sequence", check->sequence, "Sequence folder (rgb.txt, depth.txt, groundtruth.txt)")->required();
  chk->add_option("--vocab", check->vocab, "Vocabulary file")->required();
  chk->add_option("--every", check->every, "Keyframe every n-th frame")->check(CLI::Range(1, 1000000))->capture_default_str();
  chk->add_option("--max-translation", check->max_translation, "Success radius (m)")->check(finiteRange(1e-4, 1000.0))->capture_default_str();
  chk->add_option("--max-rotation", check->max_rotation_deg, "Success angle (deg)")->check(finiteRange(1e-3, 180.0))->capture_default_str();
  chk->add_flag("--verbose", check->verbose, "One line per query");
  chk->callback([check] { runCheck(*check); });
}

}  // namespace desslam::app
