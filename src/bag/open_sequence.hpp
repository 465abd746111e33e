// The inputs `desslam run` reads: a ROS 1 bag or a TUM-layout folder, chosen by the path. Here
// rather than in io because only this library links the rosbag storage library.
#pragma once

#include <filesystem>
#include <memory>

#include "bag/bag_options.hpp"
#include "io/rgbd_sequence.hpp"

namespace desslam::bag {

// Whether `path` is read as a bag: a file (a folder is a TUM sequence), or a missing path ending
// in ".bag" (so that the error speaks of the bag).
bool isBagPath(const std::filesystem::path& path);

// A bag::BagSequence (with `topics`) or an io::TumSequence; their open() errors as they are.
std::unique_ptr<io::RgbdSequence> openSequence(const std::filesystem::path& path, const BagOptions& topics);

}  // namespace desslam::bag
