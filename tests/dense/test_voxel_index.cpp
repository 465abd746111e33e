// VoxelIndex (the dense map's open-addressing key index) against std::unordered_map under a
// random mix of inserts, lookups and erases; keys drawn from a small range so that probe runs
// collide, wrap around the table and get holes punched into them by erase.
#include <random>
#include <unordered_map>

#include <gtest/gtest.h>

#include "dense/voxel_index.hpp"

namespace desslam::dense {
namespace {

TEST(VoxelIndex, AgreesWithUnorderedMapUnderRandomInsertsAndErases) {
  std::mt19937_64 rng(7);
  for (const uint64_t key_range : {uint64_t{40}, uint64_t{5000}, uint64_t{1} << 62}) {
    VoxelIndex index;
    std::unordered_map<uint64_t, uint32_t> reference;
    std::uniform_int_distribution<uint64_t> any_key(0, key_range - 1);
    std::uniform_int_distribution<int> op(0, 9);
    for (uint32_t step = 0; step < 200000; ++step) {
      const uint64_t key = any_key(rng);
      const int what = op(rng);
      if (what < 5) {
        const auto [value, inserted] = index.tryEmplace(key, step);
        const auto [it, ref_inserted] = reference.try_emplace(key, step);
        ASSERT_EQ(inserted, ref_inserted) << "key " << key;
        ASSERT_EQ(*value, it->second);
        if (what == 0) *value = it->second = step + 1;  // values are writable in place
      } else if (what < 8) {
        ASSERT_EQ(index.erase(key), reference.erase(key) == 1) << "key " << key;
      } else {
        const uint32_t* value = index.find(key);
        const auto it = reference.find(key);
        ASSERT_EQ(value != nullptr, it != reference.end()) << "key " << key;
        if (value != nullptr) {
          ASSERT_EQ(*value, it->second);
        }
      }
      ASSERT_EQ(index.size(), reference.size());
    }
    // Every key still findable after all the backward shifts.
    for (const auto& [key, value] : reference) {
      const uint32_t* found = index.find(key);
      ASSERT_NE(found, nullptr) << "key " << key;
      ASSERT_EQ(*found, value);
    }
    index.clear();
    EXPECT_TRUE(index.empty());
    EXPECT_EQ(index.find(reference.empty() ? 0 : reference.begin()->first), nullptr);
  }
}

TEST(VoxelIndex, EmptyIndexFindsAndErasesNothing) {
  VoxelIndex index;
  EXPECT_EQ(index.find(3), nullptr);
  EXPECT_FALSE(index.erase(3));
  index.reserve(1000);
  EXPECT_EQ(index.find(3), nullptr);
  EXPECT_EQ(index.size(), 0u);
}

}  // namespace
}  // namespace desslam::dense
