#include "evaluation/scoring.hpp"

#include "evaluation/baselines.hpp"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain::eval {

SegmentationScores scoreVoxels(const VoxelMap& map, const std::vector<std::uint8_t>& ground, const VoxelTruth& truth) {
  SegmentationScores out;
  std::size_t tp = 0, fp = 0, fn = 0, tn = 0;
  const auto& voxels = map.voxels();
  for (std::size_t i = 0; i < voxels.size() && i < ground.size(); ++i) {
    const TruthLabel t = truth.label(voxels[i].index);
    if (t == TruthLabel::Unknown) {
      ++out.unmatched;
      continue;
    }
    const bool p = ground[i] != 0, g = t == TruthLabel::Ground;
    if (p && g)
      ++tp;
    else if (p)
      ++fp;
    else if (g)
      ++fn;
    else
      ++tn;
  }
  out.scores = binaryScores(tp, fp, fn, tn);
  return out;
}

namespace {

// an object's surface lies within `radius` [m] of (x, y): the cell sits on the object's edge
bool objectNearby(const sim::World& world, double x, double y, double radius) {
  const int n = static_cast<int>(std::ceil(radius / 0.1));
  for (int i = -n; i <= n; ++i) {
    for (int j = -n; j <= n; ++j) {
      const double dx = radius * i / n, dy = radius * j / n;
      if (dx * dx + dy * dy > radius * radius + 1e-9) continue;
      int geom = -1;
      const double top = world.surfaceHeight(x + dx, y + dy, &geom);
      if (std::isfinite(top) && scenes::isObjectClass(world.geomClass(geom))) return true;
    }
  }
  return false;
}

// the 95th percentile (nearest rank) of a sample; NaN if it is empty
double top95(std::vector<double>& v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t k = static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(v.size()))) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

double topTolerance(const ObjectTop& t) { return std::max(1.0, 0.1 * (t.top - t.base)); }

HeightScores scoreHeights(const TerrainMesh& mesh, const VoxelMap& map, const sim::World& world,
                          const std::vector<Point3>& robot_path, const std::vector<RoofCell>& roof) {
  HeightScores out;
  const double voxel_size = map.voxelSize();
  std::vector<double> before, after, seen_before, seen_after;
  std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> bands, objects, kinds, views;
  // geom -> object id
  std::map<int, std::string> owner;
  for (const auto& o : world.truth().objects) {
    for (const auto& g : o.geoms) owner[mj_name2id(world.model(), mjOBJ_GEOM, g.c_str())] = o.id;
  }
  // per object: the heights of its cells, sensed and recovered, and their estimation outcomes
  std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> heights;
  std::map<std::string, std::array<std::uint64_t, kEstimateOutcomes>> outcomes;
  for (const auto& v : mesh.vertices()) {
    const double x = (v.cell.x() + 0.5) * voxel_size, y = (v.cell.y() + 0.5) * voxel_size;
    const CellTruth t = cellTruth(world, x, y, voxel_size);
    if (!std::isfinite(t.top)) continue;
    if (!t.object) {
      if (v.raised() && v.height() > t.top + 1.0) {
        if (objectNearby(world, x, y, 0.5))
          ++out.raised_edge_cells;
        else {
          ++out.raised_terrain_cells;
          out.raised_terrain_ground_cells += map.voxels()[v.top_voxel].label == VoxelLabel::Ground;
        }
      }
      continue;
    }
    double d = std::numeric_limits<double>::infinity();
    for (const auto& p : robot_path) d = std::min(d, std::hypot(p.x() - x, p.y() - y));
    const double eb = v.sensed_height - t.top, ea = v.height() - t.top;
    before.push_back(eb);
    after.push_back(ea);
    if (!v.estimates.empty()) seen_before.push_back(eb), seen_after.push_back(ea);
    const char* band = d < 30 ? "0-30" : d < 60 ? "30-60" : d < 100 ? "60-100" : nullptr;
    if (band) bands[band].first.push_back(eb), bands[band].second.push_back(ea);
    const std::string kind_name = world.geomClass(t.geom) == scenes::GeomClass::Building ? "building" : "tree";
    auto& kind = kinds[kind_name];
    kind.first.push_back(eb), kind.second.push_back(ea);
    // the camera saw the cell's top (its top voxel took a colour from an image)
    const bool in_view = map.voxels()[v.top_voxel].coloured;
    for (const std::string& key : {std::string(in_view ? "in_camera_view" : "never_in_camera_view"),
                                   in_view ? kind_name + "_in_camera_view" : kind_name + "_never_in_camera_view"}) {
      views[key].first.push_back(eb), views[key].second.push_back(ea);
      out.raised_by_view[key] += v.raised();
    }
    out.sensed_as_terrain += v.sensed_height < t.terrain + 0.5;
    if (auto it = owner.find(t.geom); it != owner.end()) {
      objects[it->second].first.push_back(eb);
      objects[it->second].second.push_back(ea);
      out.in_view_by_object[it->second] += in_view;
      heights[it->second].first.push_back(v.sensed_height);
      heights[it->second].second.push_back(v.height());
      auto& sum = outcomes[it->second];
      for (std::size_t k = 0; k < kEstimateOutcomes; ++k) sum[k] += v.outcomes[k];
    }
  }
  for (const auto& r : roof) {
    const CellTruth t = cellTruth(world, (r.cell.x() + 0.5) * voxel_size, (r.cell.y() + 0.5) * voxel_size, voxel_size);
    if (!t.object) continue;
    if (auto it = owner.find(t.geom); it != owner.end()) heights[it->second].second.push_back(r.height);
  }
  for (const auto& o : world.truth().objects) {
    auto it = heights.find(o.id);
    if (it == heights.end()) continue;
    ObjectTop& top = out.tops[o.id];
    top.building = o.object_class == scenes::GeomClass::Building;
    top.base = o.base_height, top.top = o.top_height;
    top.cells = it->second.second.size();
    top.sensed = top95(it->second.first);
    top.recovered = top95(it->second.second);
    if (const auto oc = outcomes.find(o.id); oc != outcomes.end()) top.outcomes = oc->second;
  }
  out.before = errorStats(before);
  out.after = errorStats(after);
  out.seen_before = errorStats(seen_before);
  out.seen_after = errorStats(seen_after);
  for (const auto& [k, v] : bands) out.by_band[k] = {errorStats(v.first), errorStats(v.second)};
  for (const auto& [k, v] : objects) out.by_object[k] = {errorStats(v.first), errorStats(v.second)};
  for (const auto& [k, v] : kinds) out.by_kind[k] = {errorStats(v.first), errorStats(v.second)};
  for (const auto& [k, v] : views) out.by_view[k] = {errorStats(v.first), errorStats(v.second)};
  return out;
}

namespace {

// inside a polygon (any orientation): crossings of a ray towards +x
bool insidePolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool in = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y()))
      in = !in;
  }
  return in;
}

}  // namespace

FootprintMatch matchFootprint(const Footprint& f, const sim::World& world, double step) {
  FootprintMatch out;
  const std::vector<Eigen::Vector2d> rect(f.corners.begin(), f.corners.end());
  // votes of the points inside the footprint for the building on top of them
  std::map<std::string, int> votes;
  std::map<int, const scenes::ObjectTruth*> by_geom;
  for (const auto& o : world.truth().objects) {
    if (o.object_class != scenes::GeomClass::Building) continue;
    for (const auto& g : o.geoms) by_geom[mj_name2id(world.model(), mjOBJ_GEOM, g.c_str())] = &o;
  }
  Eigen::Vector2d lo = rect[0], hi = rect[0];
  for (const auto& c : rect) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
  for (double y = lo.y() + 0.5 * step; y < hi.y(); y += step) {
    for (double x = lo.x() + 0.5 * step; x < hi.x(); x += step) {
      if (!insidePolygon(rect, {x, y})) continue;
      int geom = -1;
      world.surfaceHeight(x, y, &geom);
      if (auto it = by_geom.find(geom); it != by_geom.end()) ++votes[it->second->id];
    }
  }
  if (votes.empty()) return out;
  const auto best =
      std::max_element(votes.begin(), votes.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  const scenes::ObjectTruth* truth = nullptr;
  for (const auto& o : world.truth().objects) {
    if (o.id == best->first) truth = &o;
  }
  out.object = truth->id;
  out.true_top = truth->top_height;
  // intersection over union of the two footprints, on the same grid over both
  for (const auto& c : truth->footprint) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
  std::size_t both = 0, either = 0;
  for (double y = lo.y() + 0.5 * step; y < hi.y(); y += step) {
    for (double x = lo.x() + 0.5 * step; x < hi.x(); x += step) {
      const bool a = insidePolygon(rect, {x, y}), b = insidePolygon(truth->footprint, {x, y});
      both += a && b;
      either += a || b;
    }
  }
  out.iou = either ? static_cast<double>(both) / static_cast<double>(either) : 0.0;
  return out;
}

RoofScores scoreRoofCells(const std::vector<RoofCell>& roof, double voxel_size, const sim::World& world) {
  RoofScores out;
  std::vector<double> errors;
  for (const auto& r : roof) {
    const CellTruth t = cellTruth(world, (r.cell.x() + 0.5) * voxel_size, (r.cell.y() + 0.5) * voxel_size, voxel_size);
    if (!std::isfinite(t.top)) continue;
    ++out.cells;
    if (!t.object) {
      ++out.wrongly_filled;
      continue;
    }
    ++out.object_cells;
    out.building_cells += world.geomClass(t.geom) == scenes::GeomClass::Building;
    errors.push_back(r.height - t.top);
  }
  out.on_objects = errorStats(errors);
  return out;
}

HeightBaselineScores scoreHeightBaselines(const TerrainMesh& mesh, const std::vector<RoofCell>& roof, double voxel_size,
                                          const sim::World& world) {
  HeightBaselineScores out;
  const auto& verts = mesh.vertices();
  if (verts.empty()) return out;
  const auto [lo, hi] = mesh.cellBounds();
  out.span = std::max(static_cast<std::int64_t>(hi.x()) - lo.x(), static_cast<std::int64_t>(hi.y()) - lo.y()) + 1;
  if (out.span > kMaxHeightMapCells) {
    out.status = HeightBaselineScores::Status::TooWide;
    return out;
  }
  out.status = HeightBaselineScores::Status::Scored;
  const int x0 = lo.x(), y0 = lo.y(), x1 = hi.x(), y1 = hi.y();
  cv::Mat sensed(y1 - y0 + 1, x1 - x0 + 1, CV_32FC1, cv::Scalar(std::nanf(""))), recovered = sensed.clone();
  for (const auto& v : verts) {
    sensed.at<float>(v.cell.y() - y0, v.cell.x() - x0) = v.sensed_height;
    recovered.at<float>(v.cell.y() - y0, v.cell.x() - x0) = v.height();
  }
  // the recovered map also has the roofs of completed footprints (inside the mesh's extent)
  for (const auto& rc : roof) {
    const int row = rc.cell.y() - y0, col = rc.cell.x() - x0;
    if (row >= 0 && col >= 0 && row < recovered.rows && col < recovered.cols) recovered.at<float>(row, col) = rc.height;
  }
  const cv::Mat inpainted = inpaintHeights(sensed, 10);
  // object cells: the cells of object footprints inside the mapped area
  std::vector<double> e_sensed, e_inpaint, e_recovered;
  for (int r0 = 0; r0 < sensed.rows; r0 += 2) {
    for (int c0 = 0; c0 < sensed.cols; c0 += 2) {
      const double x = (x0 + c0 + 0.5) * voxel_size, y = (y0 + r0 + 0.5) * voxel_size;
      const float s = sensed.at<float>(r0, c0), si = inpainted.at<float>(r0, c0), rh = recovered.at<float>(r0, c0);
      if (!std::isfinite(si) && !std::isfinite(s)) continue;
      int geom = -1;
      const double top = world.surfaceHeight(x, y, &geom);
      if (!scenes::isObjectClass(world.geomClass(geom))) continue;
      ++out.object_cells;
      if (std::isfinite(s)) e_sensed.push_back(s - top);
      if (std::isfinite(rh)) e_recovered.push_back(rh - top);
      if (std::isfinite(si)) e_inpaint.push_back(si - top);
    }
  }
  const auto error = [&out](const std::vector<double>& e) {
    const double cells = static_cast<double>(out.object_cells);
    return HeightMapError{errorStats(e), out.object_cells ? static_cast<double>(e.size()) / cells : 0.0};
  };
  out.sensed_only = error(e_sensed);
  out.inpainting = error(e_inpaint);
  out.recovered = error(e_recovered);
  return out;
}

}  // namespace terrain::eval
