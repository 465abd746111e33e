// The public TUM reader and trajectory files (include/desslam/dataset.hpp) over desslam_io.
#include "desslam/dataset.hpp"

#include "api/pose_conversion.hpp"
#include "io/trajectory_io.hpp"
#include "io/tum_dataset.hpp"
#include "system/system_options.hpp"

namespace desslam {

TumDataset::TumDataset(std::unique_ptr<io::TumSequence> sequence) : sequence_(std::move(sequence)) {
  frames_.reserve(sequence_->size());
  for (const io::RgbdFrameRecord& r : sequence_->records())
    frames_.push_back({r.rgb_timestamp, r.depth_timestamp, r.rgb_path, r.depth_path});
}
TumDataset::TumDataset(const TumDataset& other)
    : sequence_(std::make_unique<io::TumSequence>(*other.sequence_)), frames_(other.frames_) {}
TumDataset& TumDataset::operator=(const TumDataset& other) {
  if (this != &other) {
    sequence_ = std::make_unique<io::TumSequence>(*other.sequence_);
    frames_ = other.frames_;
  }
  return *this;
}
TumDataset::TumDataset(TumDataset&&) noexcept = default;
TumDataset& TumDataset::operator=(TumDataset&&) noexcept = default;
TumDataset::~TumDataset() = default;

TumDataset TumDataset::open(const std::filesystem::path& directory, double max_dt) {
  return TumDataset(std::make_unique<io::TumSequence>(io::TumSequence::open(directory, max_dt)));
}

std::size_t TumDataset::size() const { return sequence_->size(); }

RgbdFrame TumDataset::load(std::size_t i, const Config& config) const {
  if (i >= size())
    throw InputError("TumDataset::load: frame " + std::to_string(i) + " of " + sequence_->directory().string() +
                     ", which has " + std::to_string(size()) + " frames");
  io::RgbdImage image = sequence_->load(i, config.options().camera);
  const io::RgbdFrameRecord& record = sequence_->record(i);
  // The same offset and name as `desslam run` gives the pipeline (apps/cmd_run.cpp).
  return {image.timestamp, record.depth_timestamp - record.rgb_timestamp, std::move(image.bgr),
          std::move(image.depth), record.rgb_path.filename().string()};
}

std::optional<std::vector<FramePose>> TumDataset::groundTruth() const {
  if (!sequence_->groundTruth()) return std::nullopt;
  return api::toFramePoses(*sequence_->groundTruth());
}

std::string TumDataset::groundTruthProblem() const { return sequence_->groundTruthProblem(); }

std::vector<std::string> TumDataset::warnings() const { return sequence_->warnings(); }

const std::filesystem::path& TumDataset::directory() const { return sequence_->directory(); }

std::vector<FramePose> readTumTrajectory(const std::filesystem::path& path) {
  return api::toFramePoses(io::readTumTrajectory(path));
}

void writeTumTrajectory(const std::filesystem::path& path, const std::vector<FramePose>& trajectory) {
  io::writeTumTrajectory(path, api::toTrajectory(trajectory, path.string()));
}

}  // namespace desslam
