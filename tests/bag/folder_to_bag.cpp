// desslam_folder_to_bag <tum-folder> <config.yaml> <out.bag> [16UC1]: writes the folder's paired
// frames as a ROS 1 bag in TUM's layout (bz2 chunks, 32FC1 depth unless 16UC1 is asked for), for
// checks by hand such as a whole sequence through `desslam run <bag>`. Not part of the suite.
#include <cstdio>
#include <exception>
#include <string>

#include "bag/bag_writer.hpp"
#include "io/config.hpp"
#include "io/tum_dataset.hpp"

int main(int argc, char** argv) {
  if (argc < 4 || argc > 5) {
    std::fprintf(stderr, "usage: %s <tum-folder> <config.yaml> <out.bag> [16UC1]\n", argv[0]);
    return 2;
  }
  try {
    const desslam::SystemOptions options = desslam::io::loadConfig(argv[2]);
    desslam::bag::BagWriteOptions write;
    write.topics = options.bag;
    write.depth_millimetres = argc == 5 && std::string(argv[4]) == "16UC1";
    const desslam::io::TumSequence sequence = desslam::io::TumSequence::open(argv[1]);
    desslam::bag::writeBag(sequence, options.camera, argv[3], write);
    std::printf("wrote %zu frames to %s\n", sequence.size(), argv[3]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
