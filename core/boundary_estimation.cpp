#include "core/boundary_estimation.hpp"

#include "core/camera_model.hpp"

#include <cmath>

namespace terrain {

namespace {

// mean colour of the few pixels above row `top` in column u looks like daylight sky
bool skyAbove(const cv::Mat& rgb, int u, int top, const BoundaryEstimationConfig& cfg) {
  int r = 0, g = 0, b = 0, n = 0;
  for (int row = top - 6; row <= top - 3; ++row) {
    if (row < 0) continue;
    const auto& p = rgb.at<cv::Vec3b>(row, u);
    r += p[0], g += p[1], b += p[2], ++n;
  }
  if (n == 0) return false;
  r /= n, g /= n, b /= n;
  return b >= r + cfg.sky_blue_margin && b >= g && (r + g + b) / 3 >= cfg.sky_min_brightness;
}

bool nonGround(const MeshVertex& m, const VoxelMap& map) {
  return map.voxels()[m.top_voxel].label == VoxelLabel::NonGround;
}

}  // namespace

BoundaryEstimationStats estimateBoundaries(TerrainMesh& mesh, const VoxelMap& map, const cv::Mat& boundary,
                                           const CameraIntrinsics& k, const Pose& world_from_camera,
                                           const BoundaryEstimationConfig& cfg, const cv::Mat& rgb) {
  BoundaryEstimationStats stats;
  if (boundary.empty() || boundary.type() != CV_8UC1) return stats;
  const Pose camera_from_world = world_from_camera.inverse();
  const Point3 centre = world_from_camera.translation();
  const double cell = map.voxelSize();
  auto& vertices = mesh.vertices();
  for (std::uint32_t i = 0; i < vertices.size(); ++i) {
    MeshVertex& m = vertices[i];
    if (!nonGround(m, map)) continue;
    const double x = (m.cell.x() + 0.5) * cell, y = (m.cell.y() + 0.5) * cell;
    const Point3 world(x, y, m.sensed_height);
    if ((world - centre).head<2>().norm() > cfg.max_distance) continue;
    const auto px = project(k, camera_from_world * world);
    if (!px) continue;
    ++stats.projected;
    // the object's top: the topmost boundary pixel in the column above the vertex
    const int u = static_cast<int>(px->x()), v = static_cast<int>(px->y());
    int top = -1;
    for (int row = v; row >= 0; --row) {
      if (boundary.at<std::uint8_t>(row, u)) top = row;
    }
    if (top < 0 || top <= cfg.top_margin) continue;
    if (cfg.require_sky_above && rgb.type() == CV_8UC3 && rgb.size() == boundary.size() && !skyAbove(rgb, u, top, cfg)) {
      ++stats.no_sky;
      continue;
    }
    const Vector3 dir = world_from_camera.linear() * pixelRay(k, Pixel(u + 0.5, top + 0.5));
    const double h = heightAbove(centre, dir, x, y);
    if (!std::isfinite(h) || h <= m.sensed_height || h > m.sensed_height + cfg.max_height) continue;
    mesh.addEstimate(i, static_cast<float>(h), cfg.max_estimates, cfg.fusion_quantile);
    ++stats.estimated;
  }
  return stats;
}

int spreadEstimates(TerrainMesh& mesh, const VoxelMap& map, const BoundaryEstimationConfig& cfg) {
  auto& vertices = mesh.vertices();
  for (auto& m : vertices) m.spread = false;
  const int max_hops = static_cast<int>(std::floor(cfg.spread_distance / map.voxelSize()));
  if (max_hops <= 0) return 0;
  // multi-source breadth-first walk; sources in id order, so ties go to the lower id
  std::vector<std::int64_t> source(vertices.size(), -1);
  std::vector<int> hops(vertices.size(), 0);
  std::vector<std::uint32_t> queue;
  for (std::uint32_t i = 0; i < vertices.size(); ++i) {
    if (!vertices[i].estimates.empty() && nonGround(vertices[i], map)) source[i] = i, queue.push_back(i);
  }
  int spread = 0;
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::uint32_t i = queue[q];
    if (hops[i] >= max_hops) continue;
    const CellIndex c = vertices[i].cell;
    for (const CellIndex& d : {CellIndex(1, 0), CellIndex(-1, 0), CellIndex(0, 1), CellIndex(0, -1)}) {
      const std::int64_t j = mesh.find(c + d);
      if (j < 0 || source[j] >= 0 || !nonGround(vertices[j], map)) continue;
      source[j] = source[i];
      hops[j] = hops[i] + 1;
      MeshVertex& m = vertices[j];
      m.spread = true;
      m.recovered_height = vertices[source[j]].recovered_height;
      ++spread;
      queue.push_back(static_cast<std::uint32_t>(j));
    }
  }
  return spread;
}

}  // namespace terrain
