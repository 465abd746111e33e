// Voxel key -> index: an open-addressing hash table (linear probing, power-of-two capacity,
// backward-shift deletion, so no tombstones) for the dense map's 64-bit voxel keys.
//
// Why not std::unordered_map: the dense map looks up, inserts and erases millions of keys per
// keyframe (grouping, merging, re-keying); the node map allocates a node per key and chases a
// pointer per lookup, which cost more than the geometry on Bonn crowd (profile, issue 13). Here
// a slot is 16 bytes in one array. Keys are never iterated, so the order does not matter.
//
// Keys must not equal kEmptyKey (all bits set): the dense map's packed keys use 63 bits.
// Not thread-safe (owned by one DenseMap, see dense_map.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace desslam::dense {

class VoxelIndex {
 public:
  static constexpr uint64_t kEmptyKey = ~uint64_t{0};

  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

  // Room for n keys without growing.
  void reserve(size_t n) {
    size_t capacity = slots_.empty() ? 16 : slots_.size();
    while (n > capacity / 10 * 7) capacity *= 2;  // load factor <= 0.7
    if (capacity != slots_.size()) rehash(capacity);
  }

  // The value stored for key, or nullptr.
  uint32_t* find(uint64_t key) {
    if (slots_.empty()) return nullptr;
    for (size_t i = slotOf(key);; i = (i + 1) & mask_) {
      if (slots_[i].key == key) return &slots_[i].value;
      if (slots_[i].key == kEmptyKey) return nullptr;
    }
  }
  const uint32_t* find(uint64_t key) const { return const_cast<VoxelIndex*>(this)->find(key); }

  // Inserts (key, value) unless key is present; returns the stored value and whether inserted.
  std::pair<uint32_t*, bool> tryEmplace(uint64_t key, uint32_t value) {
    reserve(size_ + 1);
    for (size_t i = slotOf(key);; i = (i + 1) & mask_) {
      if (slots_[i].key == key) return {&slots_[i].value, false};
      if (slots_[i].key == kEmptyKey) {
        slots_[i] = {key, value};
        ++size_;
        return {&slots_[i].value, true};
      }
    }
  }

  // Removes key; returns whether it was present.
  bool erase(uint64_t key) {
    if (slots_.empty()) return false;
    size_t hole = slotOf(key);
    while (slots_[hole].key != key) {
      if (slots_[hole].key == kEmptyKey) return false;
      hole = (hole + 1) & mask_;
    }
    // Backward shift: move later entries of the probe run into the hole when their home slot
    // does not lie (cyclically) between the hole and them, so every lookup still finds them.
    for (size_t next = (hole + 1) & mask_; slots_[next].key != kEmptyKey; next = (next + 1) & mask_) {
      const size_t home = slotOf(slots_[next].key);
      const bool stays = ((next - home) & mask_) < ((next - hole) & mask_);
      if (stays) continue;
      slots_[hole] = slots_[next];
      hole = next;
    }
    slots_[hole].key = kEmptyKey;
    --size_;
    return true;
  }

  void clear() {
    for (Slot& slot : slots_) slot.key = kEmptyKey;
    size_ = 0;
  }

 private:
  struct Slot {
    uint64_t key = kEmptyKey;
    uint32_t value = 0;
  };

  // splitmix64's finaliser: neighbouring voxel keys differ in a few low bits of each axis field.
  size_t slotOf(uint64_t key) const {
    key ^= key >> 30;
    key *= 0xbf58476d1ce4e5b9ULL;
    key ^= key >> 27;
    key *= 0x94d049bb133111ebULL;
    key ^= key >> 31;
    return static_cast<size_t>(key) & mask_;
  }

  void rehash(size_t capacity) {
    std::vector<Slot> old = std::move(slots_);
    slots_.assign(capacity, Slot{});
    mask_ = capacity - 1;
    size_ = 0;
    for (const Slot& slot : old)
      if (slot.key != kEmptyKey) tryEmplace(slot.key, slot.value);
  }

  std::vector<Slot> slots_;
  size_t mask_ = 0;
  size_t size_ = 0;
};

}  // namespace desslam::dense
