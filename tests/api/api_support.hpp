// What the public-API tests share: the synthetic room's config as a desslam::Config, and a test
// suite that writes one synthetic sequence into a temporary folder for all its tests.
#pragma once

#include <gtest/gtest.h>

#include "desslam/desslam.hpp"
#include "io/tum_dataset.hpp"
#include "support/temp_dir.hpp"
#include "system/system_support.hpp"

namespace desslam::test {

inline Config syntheticConfig() { return Config::fromYamlString(syntheticConfigYaml(), "synthetic.yaml"); }

// Frames: the sequence's length. Written once per suite (SetUpTestSuite), removed after it.
template <int Frames>
class SyntheticSequenceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    writeSyntheticSequence(dir_->path(), Frames);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static io::TumSequence sequence() { return io::TumSequence::open(dir_->path()); }

 private:
  static inline TempDir* dir_ = nullptr;
};

}  // namespace desslam::test
