#include "core/free_space.hpp"

#include "core/camera_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain {

namespace {

constexpr float kNone = std::numeric_limits<float>::infinity();

// a / b rounded towards minus infinity (b > 0)
int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a - 1) / b) - 1; }

}  // namespace

SkyCeiling::SkyCeiling(double cell_size) : cell_(cell_size) {}

SkyCeiling::Tile& SkyCeiling::tile(int tx, int ty) {
  auto& t = tiles_[tileKey(tx, ty)];
  if (!t) t = std::make_unique<Tile>(static_cast<std::size_t>(kTile) * kTile, kNone);
  return *t;
}

int SkyCeiling::carve(const cv::Mat& rgb, const CameraIntrinsics& k, const Pose& world_from_camera,
                      const FreeSpaceConfig& cfg, const BoundaryEstimationConfig& sky_cfg) {
  if (!cfg.enabled || rgb.empty() || rgb.type() != CV_8UC3) return 0;
  const auto sky = [&](int u, int v) {
    return looksLikeSky(rgb.at<cv::Vec3b>(v, u), sky_cfg.sky_blue_margin, sky_cfg.sky_min_brightness);
  };
  const Point3 origin = world_from_camera.translation();
  const double step = 0.5 * cell_;
  int rays = 0;
  // the tile last written, looked up again only when a ray crosses into another
  int tile_x = std::numeric_limits<int>::min(), tile_y = 0;
  Tile* current = nullptr;
  for (int u = 0; u < rgb.cols; ++u) {
    for (int v = 0; v < rgb.rows; ++v) {
      // the lowest pixel of a run of sky in the column
      if (!sky(u, v) || (v + 1 < rgb.rows && sky(u, v + 1))) continue;
      const Vector3 dir = world_from_camera.linear() * pixelRay(k, Pixel(u + 0.5, v + 0.5));
      const double horizontal = std::hypot(dir.x(), dir.y());
      if (horizontal < 1e-9) continue;  // straight up: over no cell but the camera's
      ++rays;
      // along the ray by horizontal distance d: its height rises by dir.z / horizontal per metre
      const Vector3 unit = dir / horizontal;
      for (double d = cfg.min_distance; d <= cfg.max_distance; d += step) {
        const double x = origin.x() + d * unit.x(), y = origin.y() + d * unit.y();
        const float bound = static_cast<float>(origin.z() + d * unit.z() + cfg.margin);
        const int cx = static_cast<int>(std::floor(x / cell_)), cy = static_cast<int>(std::floor(y / cell_));
        const int tx = floorDiv(cx, kTile), ty = floorDiv(cy, kTile);
        if (tx != tile_x || ty != tile_y || !current) current = &tile(tx, ty), tile_x = tx, tile_y = ty;
        float& c =
            (*current)[static_cast<std::size_t>(cy - ty * kTile) * kTile + static_cast<std::size_t>(cx - tx * kTile)];
        c = std::min(c, bound);
      }
    }
  }
  return rays;
}

float SkyCeiling::ceiling(const CellIndex& cell) const {
  const int cx = cell.x(), cy = cell.y();
  const int tx = floorDiv(cx, kTile), ty = floorDiv(cy, kTile);
  const auto it = tiles_.find(tileKey(tx, ty));
  if (it == tiles_.end()) return kNone;
  return (*it->second)[static_cast<std::size_t>(cy - ty * kTile) * kTile + static_cast<std::size_t>(cx - tx * kTile)];
}

int SkyCeiling::apply(TerrainMesh& mesh, const VoxelMap& map) const {
  int lowered = 0;
  for (MeshVertex& m : mesh.vertices()) {
    const float before = m.height();
    const bool solid = m.top_voxel < map.voxels().size() && map.voxels()[m.top_voxel].label == VoxelLabel::NonGround;
    m.ceiling = solid ? ceiling(m.cell) : kNone;
    lowered += m.raised() && m.height() < before;
  }
  return lowered;
}

std::size_t SkyCeiling::cells() const {
  std::size_t n = 0;
  for (const auto& [key, t] : tiles_)
    n += static_cast<std::size_t>(std::count_if(t->begin(), t->end(), [](float c) { return c < kNone; }));
  return n;
}

}  // namespace terrain
