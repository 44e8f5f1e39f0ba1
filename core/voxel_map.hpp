#pragma once
// Stage 2, voxel map: world points quantised into a regular grid, integrated frame by frame.
// Sparse: only occupied voxels are stored, in an open-addressing hash table keyed by the packed
// voxel index, so memory grows with the occupied voxels only. Each horizontal cell (column) keeps
// its top voxel, for the terrain mesh.

#include "core/types.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace terrain {

struct VoxelMapConfig {
  double voxel_size = 0.2;  // [m] edge of a voxel, in [0.02, 5]
};

enum class VoxelLabel : std::uint8_t { Unknown = 0, Ground = 1, NonGround = 2 };

struct Voxel {
  VoxelIndex index;                  // grid index (x, y, z)
  std::uint32_t hits = 0;            // points that fell in it
  float height = 0;                  // [m] mean world z of its points
  std::uint8_t r = 0, g = 0, b = 0;  // colour, from the camera
  bool coloured = false;
  VoxelLabel label = VoxelLabel::Unknown;
  std::uint32_t frame = 0;  // last frame that hit it
};

class VoxelMap {
 public:
  explicit VoxelMap(const VoxelMapConfig& config);

  // Adds world points from frame `frame`; returns how many new voxels were created. colours, if
  // given, has one entry per point: RGB and a last byte that is non-zero when the point was seen
  // by the camera. voxel_of, if given, receives the id of each point's voxel (kNoVoxel for a point
  // left out: not finite, or beyond the map's +-1 M voxels).
  static constexpr std::uint32_t kNoVoxel = 0xffffffffu;
  std::size_t insert(const std::vector<Point3>& points, std::uint32_t frame,
                     const std::vector<std::array<std::uint8_t, 4>>* colours = nullptr,
                     std::vector<std::uint32_t>* voxel_of = nullptr);

  // Voxel id of an index, or -1 if the voxel is empty.
  std::int64_t find(const VoxelIndex& index) const;
  const std::vector<Voxel>& voxels() const { return voxels_; }
  // The smallest and the largest index along each axis over the map's voxels (both zero while the
  // map is empty), kept as voxels are created.
  const VoxelIndex& lowestIndex() const { return lowest_; }
  const VoxelIndex& highestIndex() const { return highest_; }
  // Labels, colours and heights may be changed through this; indices may not (the hash table and
  // the index extent rest on them).
  std::vector<Voxel>& voxels() { return voxels_; }
  std::size_t size() const { return voxels_.size(); }
  // ids of voxels created since the last call
  std::vector<std::uint32_t> takeNewVoxels();

  double voxelSize() const { return size_; }
  VoxelIndex indexOf(const Point3& p) const;
  Point3 centreOf(const VoxelIndex& index) const;

  // Replaces the map's content with these voxels (a saved map read back). Returns false, leaving
  // the map empty, if two voxels share an index or one lies beyond the +-1 M voxels insert keeps.
  bool restore(std::vector<Voxel> voxels);

  // Empties the map, keeping its memory for the voxels to come.
  void clear();

  // Bytes used by the map's own storage.
  std::size_t memoryBytes() const;

  // A voxel index packed into 64 bits (21 bits per axis, +-1 M voxels): a key for hash maps.
  static std::uint64_t pack(const VoxelIndex& i);

 private:
  void grow();

  double size_;
  std::vector<Voxel> voxels_;
  VoxelIndex lowest_ = VoxelIndex::Zero(), highest_ = VoxelIndex::Zero();
  static constexpr std::uint32_t kEmpty = 0xffffffffu;
  std::vector<std::uint32_t> slots_;  // open-addressing hash table of voxel ids; the key is the voxel's index
  std::vector<std::uint32_t> new_voxels_;
};

}  // namespace terrain
