#include "evaluation/ground_truth.hpp"

#include "core/voxel_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain::eval {

std::uint64_t VoxelTruth::key(const VoxelIndex& i) { return VoxelMap::pack(i); }

Pose interpolatePose(const std::vector<rig::TimedPose>& poses, double t) {
  if (poses.empty()) return Pose::Identity();
  auto it =
      std::lower_bound(poses.begin(), poses.end(), t, [](const rig::TimedPose& p, double v) { return p.time < v; });
  if (it == poses.begin()) return it->world_from_vehicle;
  if (it == poses.end()) return poses.back().world_from_vehicle;
  const auto& b = *it;
  const auto& a = *(it - 1);
  const double s = (t - a.time) / (b.time - a.time);
  Pose p = Pose::Identity();
  p.linear() =
      Rotation(a.world_from_vehicle.linear()).slerp(s, Rotation(b.world_from_vehicle.linear())).toRotationMatrix();
  p.translation() = a.world_from_vehicle.translation() +
                    s * (b.world_from_vehicle.translation() - a.world_from_vehicle.translation());
  return p;
}

void VoxelTruth::add(const rig::RigFrame& frame, const Pose& vehicle_from_lidar) {
  if (!frame.truth || frame.truth->points.size() != frame.sensors.sweep.points.size()) return;
  // true poses over the sweep, with the neighbours of the window for interpolation at its ends
  const auto& poses = frame.truth->poses;
  for (std::size_t i = 0; i < frame.sensors.sweep.points.size(); ++i) {
    const auto& p = frame.sensors.sweep.points[i];
    const Point3 w = interpolatePose(poses, p.time) * vehicle_from_lidar * Point3(p.x, p.y, p.z);
    const VoxelIndex index(static_cast<int>(std::floor(w.x() / size_)), static_cast<int>(std::floor(w.y() / size_)),
                           static_cast<int>(std::floor(w.z() / size_)));
    auto& v = votes_[key(index)];
    const auto cls = frame.truth->points[i].cls;
    if (cls == 1)
      ++v.first;  // scenes::GeomClass::Ground
    else if (cls != 0)
      ++v.second;
  }
}

TruthLabel VoxelTruth::label(const VoxelIndex& index) const {
  auto it = votes_.find(key(index));
  // only points on geoms the truth gives no class: neither ground nor object
  if (it == votes_.end() || (it->second.first == 0 && it->second.second == 0)) return TruthLabel::Unknown;
  return it->second.first >= it->second.second ? TruthLabel::Ground : TruthLabel::NonGround;
}

std::pair<std::uint32_t, std::uint32_t> VoxelTruth::votes(const VoxelIndex& index) const {
  auto it = votes_.find(key(index));
  return it == votes_.end() ? std::pair<std::uint32_t, std::uint32_t>{0, 0} : it->second;
}

CellTruth cellTruth(const sim::World& world, double x, double y, double cell) {
  CellTruth c;
  c.top = -std::numeric_limits<double>::infinity();
  const double r = 0.4 * cell;
  for (const auto& [dx, dy] : {std::pair{0.0, 0.0}, {-r, -r}, {r, -r}, {-r, r}, {r, r}}) {
    int geom = -1;
    const double top = world.surfaceHeight(x + dx, y + dy, &geom);
    if (std::isfinite(top) && top > c.top) c.top = top, c.geom = geom;
  }
  c.terrain = world.terrainHeight(x, y);
  c.object = scenes::isObjectClass(world.geomClass(c.geom));
  return c;
}

}  // namespace terrain::eval
