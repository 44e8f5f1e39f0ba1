#pragma once
// Ground truth from the scene and the recorded truth, for scoring; it never reaches core/.
//  - per voxel: ground or non-ground by majority of the true classes of the points in it, the
//    points placed with the true vehicle poses;
//  - per horizontal cell: the true top height of whatever stands there and the true terrain height.

#include "core/types.hpp"
#include "rig/sensor_source.hpp"
#include "sim/world.hpp"

#include <cstdint>
#include <unordered_map>

namespace terrain::eval {

enum class TruthLabel : std::uint8_t { Unknown = 0, Ground = 1, NonGround = 2 };

class VoxelTruth {
 public:
  explicit VoxelTruth(double voxel_size) : size_(voxel_size) {}

  // Adds a frame's points with their true classes (frames without truth are ignored).
  void add(const rig::RigFrame& frame, const Pose& vehicle_from_lidar);
  // Ground where ground points are at least as many as object points, NonGround otherwise; Unknown
  // where no point fell, or only points on geoms the truth gives no class.
  TruthLabel label(const VoxelIndex& index) const;
  // true points in a voxel: (ground, non-ground)
  std::pair<std::uint32_t, std::uint32_t> votes(const VoxelIndex& index) const;
  std::size_t size() const { return votes_.size(); }
  double voxelSize() const { return size_; }
  // every voxel's votes by packed index (VoxelMap::pack), and adding to them (a saved truth read back)
  const std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>>& allVotes() const { return votes_; }
  void addVotes(std::uint64_t packed_index, std::uint32_t ground, std::uint32_t non_ground) {
    auto& v = votes_[packed_index];
    v.first += ground;
    v.second += non_ground;
  }

 private:
  static std::uint64_t key(const VoxelIndex& i);
  double size_;
  std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>> votes_;  // ground, non-ground
};

// True vehicle pose at time t from time-sorted true poses (slerp between neighbours).
Pose interpolatePose(const std::vector<rig::TimedPose>& poses, double t);

// True height [m] of the highest surface within the square cell of edge `cell` centred on (x, y)
// (sampled at its centre and four points near its corners), and whether an object is it.
struct CellTruth {
  double top = 0;
  double terrain = 0;
  bool object = false;
  int geom = -1;
};
CellTruth cellTruth(const sim::World& world, double x, double y, double cell);

}  // namespace terrain::eval
