#include "core/voxel_map.hpp"

#include "core/large_buffers.hpp"

#include <algorithm>
#include <cmath>

namespace terrain {

namespace {

constexpr int kBits = 21;  // per axis: +-1M voxels
constexpr std::int64_t kOffset = std::int64_t{1} << (kBits - 1);
constexpr std::uint64_t kMask = (std::uint64_t{1} << kBits) - 1;

std::uint64_t hashKey(std::uint64_t k) {
  k ^= k >> 33;
  k *= 0xff51afd7ed558ccdull;
  k ^= k >> 33;
  return k;
}

}  // namespace

VoxelMap::VoxelMap(const VoxelMapConfig& config) : size_(config.voxel_size) { slots_.assign(1 << 16, kEmpty); }

std::uint64_t VoxelMap::pack(const VoxelIndex& i) {
  return ((static_cast<std::uint64_t>(i.x() + kOffset) & kMask) << (2 * kBits)) |
         ((static_cast<std::uint64_t>(i.y() + kOffset) & kMask) << kBits) |
         (static_cast<std::uint64_t>(i.z() + kOffset) & kMask);
}

VoxelIndex VoxelMap::indexOf(const Point3& p) const {
  return {static_cast<int>(std::floor(p.x() / size_)), static_cast<int>(std::floor(p.y() / size_)),
          static_cast<int>(std::floor(p.z() / size_))};
}

Point3 VoxelMap::centreOf(const VoxelIndex& i) const { return (i.cast<double>().array() + 0.5) * size_; }

std::int64_t VoxelMap::find(const VoxelIndex& index) const {
  const std::size_t mask = slots_.size() - 1;
  for (std::size_t s = hashKey(pack(index)) & mask;; s = (s + 1) & mask) {
    if (slots_[s] == kEmpty) return -1;
    if (voxels_[slots_[s]].index == index) return slots_[s];
  }
}

void VoxelMap::grow() {
  std::vector<std::uint32_t> slots;
  assignLarge(slots, slots_.size() * 2, kEmpty);
  const std::size_t mask = slots.size() - 1;
  for (std::uint32_t id = 0; id < voxels_.size(); ++id) {
    std::size_t t = hashKey(pack(voxels_[id].index)) & mask;
    while (slots[t] != kEmpty) t = (t + 1) & mask;
    slots[t] = id;
  }
  slots_.swap(slots);
}

bool VoxelMap::restore(std::vector<Voxel> voxels) {
  voxels_ = std::move(voxels);
  new_voxels_.clear();
  const auto reject = [this] {
    voxels_.clear();
    slots_.assign(1 << 16, kEmpty);
    lowest_ = highest_ = VoxelIndex::Zero();
    return false;
  };
  lowest_ = highest_ = voxels_.empty() ? VoxelIndex::Zero() : voxels_[0].index;
  for (const Voxel& v : voxels_) {
    // the indices insert can create
    for (int a = 0; a < 3; ++a) {
      if (v.index[a] < -(kOffset - 1) || v.index[a] > kOffset - 1) return reject();
    }
    lowest_ = lowest_.cwiseMin(v.index), highest_ = highest_.cwiseMax(v.index);
  }
  std::size_t n = 1 << 16;
  while (n < 2 * (voxels_.size() + 1)) n *= 2;
  assignLarge(slots_, n, kEmpty);
  const std::size_t mask = n - 1;
  for (std::uint32_t id = 0; id < voxels_.size(); ++id) {
    std::size_t t = hashKey(pack(voxels_[id].index)) & mask;
    while (slots_[t] != kEmpty) {
      if (voxels_[slots_[t]].index == voxels_[id].index) return reject();
      t = (t + 1) & mask;
    }
    slots_[t] = id;
  }
  return true;
}

std::size_t VoxelMap::insert(const std::vector<Point3>& points, std::uint32_t frame,
                             const std::vector<std::array<std::uint8_t, 4>>* colours,
                             std::vector<std::uint32_t>* voxel_of) {
  const std::size_t before = voxels_.size();
  const double limit = static_cast<double>(kOffset - 1) * size_;
  if (voxel_of) voxel_of->assign(points.size(), kNoVoxel);
  // In blocks of points: first every point's index and hash (no memory but the points'), then the
  // look-ups in point order, each slot and its voxel fetched from memory a few points ahead, so
  // that the table's cache misses overlap instead of following one another.
  constexpr std::size_t kBlock = 256, kSlotAhead = 16, kVoxelAhead = 8;
  constexpr std::uint64_t kSkip = ~std::uint64_t{0};  // hash of a point left out
  std::array<VoxelIndex, kBlock> index;
  std::array<std::uint64_t, kBlock> hash;
  for (std::size_t first = 0; first < points.size(); first += kBlock) {
    const std::size_t count = std::min(kBlock, points.size() - first);
    for (std::size_t j = 0; j < count; ++j) {
      const Point3& p = points[first + j];
      const bool keep = p.allFinite() && p.cwiseAbs().maxCoeff() < limit;
      index[j] = keep ? indexOf(p) : VoxelIndex::Zero();
      hash[j] = keep ? hashKey(pack(index[j])) : kSkip;
    }
    for (std::size_t j = 0; j < count; ++j) {
      if (hash[j] != kSkip && 2 * (voxels_.size() + 1) > slots_.size()) grow();
      const std::size_t mask = slots_.size() - 1;
      if (j + kSlotAhead < count && hash[j + kSlotAhead] != kSkip)
        __builtin_prefetch(&slots_[hash[j + kSlotAhead] & mask]);
      if (j + kVoxelAhead < count && hash[j + kVoxelAhead] != kSkip) {
        const std::uint32_t id = slots_[hash[j + kVoxelAhead] & mask];
        if (id != kEmpty) __builtin_prefetch(&voxels_[id]);
      }
      if (hash[j] == kSkip) continue;
      const std::size_t k = first + j;
      const Point3& p = points[k];
      std::size_t s = hash[j] & mask;
      while (slots_[s] != kEmpty && voxels_[slots_[s]].index != index[j]) s = (s + 1) & mask;
      if (slots_[s] == kEmpty) {
        slots_[s] = static_cast<std::uint32_t>(voxels_.size());
        if (voxels_.empty()) lowest_ = highest_ = index[j];
        lowest_ = lowest_.cwiseMin(index[j]), highest_ = highest_.cwiseMax(index[j]);
        Voxel v;
        v.index = index[j];
        // grown as push_back grows them, into memory advised for huge pages
        reserveLarge(voxels_, voxels_.size() + 1), reserveLarge(new_voxels_, new_voxels_.size() + 1);
        voxels_.push_back(v);
        new_voxels_.push_back(slots_[s]);
      }
      if (voxel_of) (*voxel_of)[k] = slots_[s];
      Voxel& v = voxels_[slots_[s]];
      // running mean of the points' heights
      v.hits += 1;
      v.height += static_cast<float>((p.z() - v.height) / v.hits);
      v.frame = frame;
      if (colours && (*colours)[k][3]) {
        const auto& c = (*colours)[k];
        v.r = c[0], v.g = c[1], v.b = c[2];
        v.coloured = true;
      }
    }
  }
  return voxels_.size() - before;
}

void VoxelMap::clear() {
  voxels_.clear();
  new_voxels_.clear();
  std::fill(slots_.begin(), slots_.end(), kEmpty);
  lowest_ = highest_ = VoxelIndex::Zero();
}

std::vector<std::uint32_t> VoxelMap::takeNewVoxels() {
  std::vector<std::uint32_t> out;
  out.swap(new_voxels_);
  return out;
}

std::size_t VoxelMap::memoryBytes() const {
  return voxels_.capacity() * sizeof(Voxel) + slots_.capacity() * sizeof(std::uint32_t) +
         new_voxels_.capacity() * sizeof(std::uint32_t);
}

}  // namespace terrain
