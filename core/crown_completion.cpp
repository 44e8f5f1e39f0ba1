#include "core/crown_completion.hpp"

#include "core/camera_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

namespace terrain {

namespace {

// the element at quantile q (clamped to [0, 1]) of a sorted, non-empty list: index floor(q n)
float quantile(const std::vector<float>& sorted, double q) {
  const double at = std::clamp(q, 0.0, 1.0) * static_cast<double>(sorted.size());
  return sorted[std::min(sorted.size() - 1, static_cast<std::size_t>(at))];
}

}  // namespace

double groundAround(const Trunk& t, const TerrainMesh& mesh, const VoxelMap& map) {
  const auto& vertices = mesh.vertices();
  const int ring = static_cast<int>(std::ceil(1.0 / map.voxelSize()));
  double ground = std::numeric_limits<double>::infinity();
  for (int y = t.lo.y() - ring; y <= t.hi.y() + ring; ++y) {
    for (int x = t.lo.x() - ring; x <= t.hi.x() + ring; ++x) {
      const std::int64_t j = mesh.find(CellIndex(x, y));
      if (j >= 0 && map.voxels()[vertices[j].top_voxel].label == VoxelLabel::Ground)
        ground = std::min(ground, static_cast<double>(vertices[j].sensed_height));
    }
  }
  return ground;
}

bool standsAboveGround(const Trunk& t, double ground, double min_height) {
  return !std::isfinite(ground) || t.top - ground >= min_height;
}

bool fitsWithin(const Trunk& t, double width, double cell) {
  return ((t.hi - t.lo).array() + 1).maxCoeff() * cell <= width;
}

std::vector<Trunk> findTrunks(const TerrainMesh& mesh, const VoxelMap& map, const MeshObjects& objects,
                              double max_width) {
  const auto& vertices = mesh.vertices();
  const double cell = map.voxelSize();
  struct Extent {
    int n = 0, x0 = 0, x1 = 0, y0 = 0, y1 = 0;
    std::uint32_t first = 0;
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    double top = -1e300;
  };
  std::vector<Extent> extents(objects.count);
  for (std::uint32_t i : objects.members) {
    Extent& e = extents[objects.of[i]];
    const CellIndex c = vertices[i].cell;
    if (e.n == 0) e.first = i, e.x0 = e.x1 = c.x(), e.y0 = e.y1 = c.y();
    e.first = std::min(e.first, i);
    e.x0 = std::min(e.x0, c.x()), e.x1 = std::max(e.x1, c.x()), e.y0 = std::min(e.y0, c.y()),
    e.y1 = std::max(e.y1, c.y());
    e.sum += Eigen::Vector2d((c.x() + 0.5) * cell, (c.y() + 0.5) * cell);
    e.top = std::max(e.top, static_cast<double>(vertices[i].sensed_height));
    ++e.n;
  }
  std::vector<Trunk> trunks;
  for (std::int32_t o = 0; o < objects.count; ++o) {
    const Extent& e = extents[o];
    if (e.n == 0 || (e.x1 - e.x0 + 1) * cell > max_width || (e.y1 - e.y0 + 1) * cell > max_width) continue;
    trunks.push_back({e.first, o, e.sum / e.n, e.top, CellIndex(e.x0, e.y0), CellIndex(e.x1, e.y1)});
  }
  return trunks;
}

const char* outcomeName(CrownOutcome outcome) {
  switch (outcome) {
    case CrownOutcome::Measured:
      return "measured";
    case CrownOutcome::NoCrown:
      return "no_crown";
    case CrownOutcome::TooShort:
      return "too_short";
    case CrownOutcome::Unbounded:
      return "unbounded";
    case CrownOutcome::OffCentre:
      return "off_centre";
    case CrownOutcome::NearerTrunk:
      return "nearer_trunk";
    case CrownOutcome::Implausible:
      return "implausible";
    case CrownOutcome::NotClear:
      return "not_clear";
    case CrownOutcome::NotAboveGround:
      return "not_above_ground";
    case CrownOutcome::CutOff:
      return "cut_off";
  }
  return "unknown";
}

const char* verdictName(CrownVerdict verdict) {
  switch (verdict) {
    case CrownVerdict::NotApplied:
      return "not_applied";
    case CrownVerdict::TooFewSamples:
      return "too_few_samples";
    case CrownVerdict::NoBaseline:
      return "no_baseline";
    case CrownVerdict::Sunk:
      return "sunk";
    case CrownVerdict::Disagree:
      return "disagree";
    case CrownVerdict::TooNarrow:
      return "too_narrow";
    case CrownVerdict::Raised:
      return "raised";
    case CrownVerdict::RaisedToBound:
      return "raised_to_bound";
    case CrownVerdict::RaisedFromColumns:
      return "raised_from_columns";
  }
  return "unknown";
}

std::vector<CrownRecord> CrownSampler::records() const {
  std::vector<CrownRecord> out;
  out.reserve(records_.size());
  for (const auto& [key, r] : records_) out.push_back(r);
  std::sort(out.begin(), out.end(), [](const CrownRecord& a, const CrownRecord& b) { return a.key < b.key; });
  return out;
}

void CrownSampler::restoreRecords(const std::vector<CrownRecord>& records) {
  records_.clear();
  for (const CrownRecord& r : records) records_[r.key] = r;
}

bool parseCrownCue(const std::string& s, CrownConfig::Cue& out) {
  if (s == "foliage") return out = CrownConfig::Cue::Foliage, true;
  if (s == "sky") return out = CrownConfig::Cue::Sky, true;
  return false;
}

double CrownSampler::ownersReach(const CrownConfig& config, const BoundaryEstimationConfig& estimation) {
  return estimation.max_distance + config.max_radius;
}

int CrownSampler::measure(const TerrainMesh& mesh, const VoxelMap& map, const cv::Mat& rgb, const CameraIntrinsics& k,
                          const Pose& world_from_camera, const CrownConfig& cfg,
                          const BoundaryEstimationConfig& sky_cfg, const SkylineOwners* given_owners) {
  if (!cfg.enabled || rgb.empty() || rgb.type() != CV_8UC3 || mesh.vertices().empty()) return 0;
  const Pose camera_from_world = world_from_camera.inverse();
  const Point3 centre = world_from_camera.translation();
  // the objects in view within max_distance and a crown's radius of the camera: the trunks measured,
  // and what their clear lines may cross
  std::optional<SkylineOwners> own_owners;
  const SkylineOwners& owners =
      given_owners ? *given_owners
                   : own_owners.emplace(mesh, map, viewRegion(k, world_from_camera, ownersReach(cfg, sky_cfg)));
  const MeshObjects& objects = owners.objects();
  auto sky = [&](int u, int row) {
    return looksLikeSky(rgb.at<cv::Vec3b>(row, u), sky_cfg.sky_blue_margin, sky_cfg.sky_min_brightness);
  };
  const bool foliage_cue = cfg.cue == CrownConfig::Cue::Foliage;
  auto crown = [&](int u, int row) {
    return foliage_cue ? looksLikeFoliage(rgb.at<cv::Vec3b>(row, u), cfg.foliage_margin) : !sky(u, row);
  };
  // where every trunk's top appears in the image (u < 0: not in the image); the crown above it lies
  // on the image of the vertical through it
  struct View {
    int u = -1, v = -1;
    Pixel px = Pixel::Zero();
    double depth = 0;  // [m] along the optical axis
  };
  const Verticals verticals(k, world_from_camera);
  // the trunks (the first `trunks`), then, with grown_owners, the trees whose crown's underside the lidar reached
  // (wider than a trunk, no wider than max_grown_width): they are not measured, but one nearer the camera may own a run
  const bool grown_owners = cfg.grown_owners && foliage_cue;
  std::vector<Trunk> standing, wider;
  for (const Trunk& t : findTrunks(
           mesh, map, objects, grown_owners ? std::max(cfg.max_trunk_width, cfg.max_grown_width) : cfg.max_trunk_width))
    (fitsWithin(t, cfg.max_trunk_width, map.voxelSize()) ? standing : wider).push_back(t);
  const std::size_t trunks = standing.size();
  standing.insert(standing.end(), wider.begin(), wider.end());
  // with the foliage cue, only another tree can own a crown's pixel: a building behind or before the
  // crown is not foliage
  std::vector<char> trunk_like(objects.count, 0);
  for (std::size_t i = 0; i < trunks; ++i) trunk_like[standing[i].object] = 1;
  std::vector<View> views(standing.size());
  for (std::size_t i = 0; i < standing.size(); ++i) {
    const Point3 p = camera_from_world * Point3(standing[i].centre.x(), standing[i].centre.y(), standing[i].top);
    const auto px = project(k, p);
    if (px && px->x() < rgb.cols && px->y() < rgb.rows)
      views[i] = {static_cast<int>(px->x()), static_cast<int>(px->y()), *px, p.z()};
  }
  // the column at `row` of the vertical through the top of trunk i (may lie outside the image)
  const auto column = [&](std::size_t i, int row) {
    return static_cast<int>(std::floor(verticals.columnAt(views[i].px, row + 0.5)));
  };
  const auto inside = [&](int u) { return u >= 0 && u < rgb.cols; };
  // the run of crown pixels of `row` around column u: its first and last column
  const auto runAround = [&](int u, int row) {
    int left = u, right = u;
    while (left - 1 >= 0 && crown(left - 1, row)) --left;
    while (right + 1 < rgb.cols && crown(right + 1, row)) ++right;
    return std::pair<int, int>(left, right);
  };
  // the ray through the vertical of trunk i at `row` (world frame)
  const auto rayAt = [&](std::size_t i, double row) {
    return Vector3(world_from_camera.linear() * pixelRay(k, Pixel(verticals.columnAt(views[i].px, row), row)));
  };
  // [m] how far from the vertical of trunk i the edge of a run at image column `edge` (a pixel
  // boundary) of `row` lies: where the ray through it passes the vertical (acrossVertical). Off the
  // optical axis the pinhole stretches widths; pixels times depth / fx would widen such a crown
  const auto across = [&](std::size_t i, int row, double edge) {
    return acrossVertical(centre, world_from_camera.linear() * pixelRay(k, Pixel(edge, row + 0.5)),
                          standing[i].centre.x(), standing[i].centre.y());
  };
  // the axis's ceiling over trunk i in this image (CrownConfig::axis_ceiling): the height where the
  // lowest rising ray above the trunk's top crosses its vertical with the sky on both sides of it;
  // +inf if none does within the image
  const auto axisCeiling = [&](std::size_t i) {
    const Trunk& t = standing[i];
    const int half = static_cast<int>(std::ceil(cfg.ceiling_halfwidth * k.fx / views[i].depth));
    for (int row = views[i].v - 1; row >= 0; --row) {
      const int u = column(i, row);
      if (!inside(u - half) || !inside(u + half)) break;
      bool clear = sky(u, row);
      for (int du = 1; du <= half && clear; ++du) clear = sky(u - du, row) && sky(u + du, row);
      if (!clear) continue;
      const Vector3 dir = rayAt(i, row + 0.5);
      if (dir.z() <= 0) continue;  // a falling ray may pass beyond the world's edge
      const double h = heightAbove(centre, dir, t.centre.x(), t.centre.y());
      // a ray below the trunk's sensed top crossed beside it, not over it
      return std::isfinite(h) && h > t.top ? h : std::numeric_limits<double>::infinity();
    }
    return std::numeric_limits<double>::infinity();
  };
  int measured = 0;
  std::vector<std::pair<int, double>> profile;  // (row, half width there [m]) of the runs kept
  std::vector<double> fits;                     // [m] the radii of the ellipses through them
  for (std::size_t i = 0; i < trunks; ++i) {
    const Trunk& t = standing[i];
    const int v = views[i].v;
    if (views[i].u < 0) continue;
    CrownRecord& record = records_[t.key];
    record.key = t.key;
    record.centre = t.centre.cast<float>();
    const auto count = [&record](CrownOutcome o) { countUp(record.outcomes[static_cast<std::size_t>(o)]); };
    if (cfg.axis_ceiling) {
      const double ceiling = axisCeiling(i);
      if (std::isfinite(ceiling)) ceilings_[t.key].push_back(static_cast<float>(ceiling));
    }
    // the crown's rows on the trunk's vertical, [top, bottom], and its widest run. With the foliage
    // cue a crown above the trunk that a tree nearer the camera owns hides the trunk: the walk goes
    // on up the trunk's vertical above it (within max_trunk_gap of the trunk's sensed top)
    const int gap = static_cast<int>(std::ceil(cfg.max_trunk_gap * k.fy / views[i].depth));
    std::optional<CrownOutcome> failed;
    bool cut = false;
    int top = v, bottom = v - 1, widest = 0, widest_left = 0, widest_row = v, own = 0;
    double half = 0;  // [m] the crown's half width at the trunk's vertical
    // the crown's lowest row over the bare trunk on the first walk, and the top row of the crown the
    // last walk went up (-1: it met none), for column samples
    int first_bottom = -1, column_top = -1;
    double run_centre = 0;
    for (int start = v;;) {
      top = start, bottom = start - 1, column_top = -1;
      if (foliage_cue) {
        // up the bare trunk (neither foliage nor sky) to the crown's lowest pixel, then up the crown
        int row = start;
        while (row >= 0 && v - row <= gap && inside(column(i, row)) && !crown(column(i, row), row) &&
               !sky(column(i, row), row))
          --row;
        if (row < 0 || v - row > gap || !inside(column(i, row)) || !crown(column(i, row), row)) {
          if (!failed) failed = CrownOutcome::NoCrown;  // no crown above the bare trunk
          break;
        }
        bottom = row;
        top = row;
        if (first_bottom < 0) first_bottom = row;
      }
      while (top - 1 >= 0 && inside(column(i, top - 1)) && crown(column(i, top - 1), top - 1)) --top;
      column_top = top;
      // cut off by the image top (with cut_off_tops, a bound on the top from below), or too little
      // crown
      cut = top == 0;
      if ((cut && !cfg.cut_off_tops) || bottom - top + 1 < cfg.min_height_px) {
        failed = CrownOutcome::TooShort;
        break;
      }
      // the crown's runs around the vertical, row by row down from the top, while the cue bounds
      // them on both sides and neither end jumps outwards (something behind joining the crown): the
      // widest, and the crown's half width as the largest distance from the vertical to the nearer
      // end of a run (a crown beside it, joined on one side, does not widen it). A crown cut off by
      // the image top, near the camera, may fill the image's width at the top: its runs from the
      // first one bounded on both sides. With one_sided, a jump at one end only stops the widest
      // run there, and the other end goes on (CrownConfig::one_sided)
      widest = 0, widest_left = 0, widest_row = top, half = 0;
      profile.clear();
      int prev_left = column(i, top), prev_right = prev_left, bounded = 0;
      // how far each end moved out at the row before: a crown's outline widens less and less down
      // to its widest row (steeply near its top), so only an end that moves out by more than `jump`
      // and by more than it did at the row before (2 px of slack) is something behind joining it
      int grew_left = 0, grew_right = 0;
      // with one_sided, the ends that something behind has joined: their runs no longer bound the
      // crown, and the other end alone goes on giving the half width
      bool joined_left = false, joined_right = false;
      for (int row = top; row <= bottom; ++row) {
        const int u = column(i, row);
        if (!inside(u)) break;
        const auto [left, right] = runAround(u, row);
        if ((left == 0 && !joined_left) || (right == rgb.cols - 1 && !joined_right)) {
          if (cut && bounded == 0) continue;
          break;
        }
        // the crown's width at the row before, from the ends that still bound it
        const int width = joined_left    ? 2 * (prev_right - u) + 1
                          : joined_right ? 2 * (u - prev_left) + 1
                                         : prev_right - prev_left + 1;
        const int jump = std::max(3, width / 10);
        const int out_left = prev_left - left, out_right = right - prev_right;
        const bool jumps_left = !joined_left && out_left > jump && out_left > grew_left + 2;
        const bool jumps_right = !joined_right && out_right > jump && out_right > grew_right + 2;
        if (bounded >= 2 && (jumps_left || jumps_right)) {
          if (!cfg.one_sided || joined_left || joined_right || (jumps_left && jumps_right)) break;
          joined_left = jumps_left, joined_right = jumps_right;
        }
        grew_left = out_left, grew_right = out_right;
        // the crown's half width at this row: the distance from the vertical to the run's nearer end
        // (a pixel edge), or to the end that still bounds it
        const double w = joined_left    ? across(i, row, right + 1)
                         : joined_right ? across(i, row, left)
                                        : std::min(across(i, row, left), across(i, row, right + 1));
        if (!joined_left && !joined_right && right - left + 1 > widest)
          widest = right - left + 1, widest_left = left, widest_row = row;
        half = std::max(half, w);
        profile.emplace_back(row, w);
        prev_left = left, prev_right = right;
        ++bounded;
      }
      if (widest == 0) {
        failed = CrownOutcome::Unbounded;
        break;
      }
      // a crown stands over its trunk: a widest run centred away from the trunk's vertical is
      // another tree's crown, nearer or farther (the clear-line test knows only sensed objects, and
      // crowns are above the lidar's reach)
      run_centre = widest_left + 0.5 * (widest - 1);
      own = column(i, widest_row);
      if (std::abs(run_centre - own) > cfg.max_offcentre * widest + 1.0) {
        failed = CrownOutcome::OffCentre;
        break;
      }
      // of the trunks standing under the run (their tops below the crown's), the one nearest its
      // centre owns it; a grown tree (grown_owners) nearer the camera also where it stands as near
      // the centre (within 1.5 px): its trunk and crown then cover the column that was climbed
      std::optional<std::size_t> owner;
      for (std::size_t j = 0; j < standing.size() && !owner; ++j) {
        if (j == i || views[j].u < 0) continue;
        // a grown tree owns a run only from farther than max_grown_width from the trunk: nearer, it
        // may be a fragment of the trunk's own tree (its crown's underside)
        const bool grown = j >= trunks;
        if (grown &&
            (views[j].depth >= views[i].depth || (standing[j].centre - t.centre).norm() <= cfg.max_grown_width))
          continue;
        const int other = column(j, widest_row);
        if (other >= widest_left && other < widest_left + widest && views[j].v > top &&
            std::abs(other - run_centre) < std::abs(own - run_centre) + (grown ? 1.5 : 0.0))
          owner = j;
      }
      if (!owner) {
        failed.reset();
        break;
      }
      failed = CrownOutcome::NearerTrunk;
      if (!foliage_cue || views[*owner].depth >= views[i].depth) break;
      start = top - 1;  // the nearer tree's crown hides this trunk: on up above it
    }
    if (failed) {
      count(*failed);
      // the crown's column still bounds its top from above where a crown joined it (off centre, under
      // another trunk's run, or touching the image's sides): a column sample
      if (cfg.column_tops && foliage_cue && column_top > 0 && first_bottom >= 0 &&
          (*failed == CrownOutcome::OffCentre || *failed == CrownOutcome::NearerTrunk ||
           *failed == CrownOutcome::Unbounded)) {
        const double height = heightAbove(centre, rayAt(i, column_top + 0.5), t.centre.x(), t.centre.y());
        // the crown starts above the bare trunk the lidar saw (a crown whose foot the lidar reached
        // may be all there is: what stands over it in the column is another's)
        const double foot = heightAbove(centre, rayAt(i, first_bottom + 1.0), t.centre.x(), t.centre.y());
        // a crown's apex stands over its trunk: the runs of the column's top rows (as many as the
        // crown's top metre spans) centred on the vertical; one centred away is the shoulder of another
        const int apex_rows = std::max(2, static_cast<int>(std::lround(k.fy / views[i].depth)));
        double apex = 0;
        int apex_n = 0, apex_width = 0;
        for (int row = column_top; row < column_top + apex_rows; ++row) {
          const int u = column(i, row);
          if (!inside(u) || !crown(u, row)) break;
          const auto [left, right] = runAround(u, row);
          apex += 0.5 * (left + right) - u, ++apex_n, apex_width = right - left + 1;
        }
        const bool centred = apex_n > 0 && std::abs(apex / apex_n) <= cfg.max_offcentre * apex_width + 1.0;
        if (centred && std::isfinite(height) && std::isfinite(foot) && foot >= t.top + cfg.column_min_bare &&
            height > foot && standsAboveGround(t, groundAround(t, mesh, map), cfg.min_trunk_height)) {
          double radius = half;
          if (cfg.max_width_to_depth > 0) radius = std::min(radius, 0.5 * cfg.max_width_to_depth * (height - foot));
          if (radius > cfg.max_radius) radius = 0;
          columns_[t.key].push_back({static_cast<float>(height), static_cast<float>(radius),
                                     centre.head<2>().cast<float>(), t.centre.cast<float>(), false, true});
        }
      }
      continue;
    }
    const Vector3 dir = rayAt(i, top + 0.5);
    const double height = heightAbove(centre, dir, t.centre.x(), t.centre.y());
    double radius = half;
    if (!std::isfinite(height) || height <= t.top || !(radius <= cfg.max_radius)) {
      count(CrownOutcome::Implausible);
      continue;
    }
    // a crown is at most max_width_to_depth times as wide as it is deep (its top above its lowest
    // pixel on the vertical): wider, the runs took in crowns behind it on both sides. A crown cut
    // off by the image top is deeper than it shows: no bound
    const double lowest = heightAbove(centre, rayAt(i, bottom + 1.0), t.centre.x(), t.centre.y());
    if (cfg.ellipse_radius && !cut && std::isfinite(lowest) && height > lowest) {
      const double b = 0.5 * (height - lowest);
      fits.clear();
      for (const auto& [row, w] : profile) {
        const double h = heightAbove(centre, rayAt(i, row + 0.5), t.centre.x(), t.centre.y());
        const double q = (height - h) / b;
        if (std::isfinite(h) && q >= cfg.ellipse_min_depth && q <= 2 - cfg.ellipse_min_depth)
          fits.push_back(w / std::sqrt(1 - (1 - q) * (1 - q)));
      }
      if (!fits.empty()) {
        std::nth_element(fits.begin(), fits.begin() + fits.size() / 2, fits.end());
        radius = std::min(cfg.max_radius, std::max(radius, fits[fits.size() / 2]));
      }
    }
    if (!cut && std::isfinite(lowest) && cfg.max_width_to_depth > 0)
      radius = std::min(radius, 0.5 * cfg.max_width_to_depth * std::max(0.0, height - lowest));
    // the clear line reaches past a trunk farther than max_distance, to the far side of its crown
    const double reach = std::max(sky_cfg.max_distance, (t.centre - centre.head<2>()).norm() + cfg.max_radius);
    if (sky_cfg.clear_line &&
        owners.otherMayOwn(centre, dir, reach, t.object, t.centre, 1.0, 1.0, foliage_cue ? &trunk_like : nullptr)) {
      count(CrownOutcome::NotClear);
      continue;
    }
    // one that does not stand above its ground is measured for no crown (but may own one above)
    if (!standsAboveGround(t, groundAround(t, mesh, map), cfg.min_trunk_height)) {
      count(CrownOutcome::NotAboveGround);
      continue;
    }
    count(cut ? CrownOutcome::CutOff : CrownOutcome::Measured);
    samples_[t.key].push_back({static_cast<float>(height), static_cast<float>(radius), centre.head<2>().cast<float>(),
                               t.centre.cast<float>(), cut, false});
    ++measured;
  }
  return measured;
}

int CrownSampler::apply(TerrainMesh& mesh, const VoxelMap& map, const CrownConfig& cfg, const SkyThrough& sky_through) {
  lowered_ = 0, lowered_by_cap_ = 0;
  if (!cfg.enabled || (samples_.empty() && columns_.empty() && ceilings_.empty()) || mesh.vertices().empty()) return 0;
  const MeshObjects objects = findMeshObjects(mesh, map);
  auto& vertices = mesh.vertices();
  const double cell = map.voxelSize();
  int raised = 0;
  // only trunks with samples count: the wider limit lets in those that have grown since. An object
  // wider still, up to a crown's width, may be a trunk that the lidar saw grow into its crown's
  // underside as the robot neared: it is judged once its samples give the crown's radius.
  const double grown_width = std::max(cfg.max_trunk_width, cfg.max_grown_width);
  std::vector<Trunk> trunks;
  std::unordered_map<std::int32_t, Trunk> wide;  // by object
  for (const Trunk& t : findTrunks(mesh, map, objects, 2 * cfg.max_radius)) {
    if (fitsWithin(t, grown_width, cell)) {
      trunks.push_back(t);
    } else {
      wide.emplace(t.object, t);
    }
  }
  const std::size_t narrow = trunks.size();
  std::unordered_map<std::int32_t, std::size_t> grown_of_object;  // the wide objects taken as trunks
  // the object with a vertex nearest p within 1 m; -1 if none
  const auto objectNear = [&](const Eigen::Vector2d& p) {
    const int ring = static_cast<int>(std::ceil(1.0 / cell));
    const CellIndex c0(static_cast<int>(std::floor(p.x() / cell)), static_cast<int>(std::floor(p.y() / cell)));
    std::int32_t best = -1;
    double best_d2 = 1.0;
    for (int dy = -ring; dy <= ring; ++dy) {
      for (int dx = -ring; dx <= ring; ++dx) {
        const std::int64_t j = mesh.find(c0 + CellIndex(dx, dy));
        if (j < 0 || objects.of[j] < 0) continue;
        const Eigen::Vector2d q((vertices[j].cell.x() + 0.5) * cell, (vertices[j].cell.y() + 0.5) * cell);
        if ((q - p).squaredNorm() <= best_d2) best_d2 = (q - p).squaredNorm(), best = objects.of[j];
      }
    }
    return best;
  };
  // each key's samples go to the trunk of that key, else to the trunk nearest their last sample's
  // trunk position within 1 m, else to the grown trunk under it (standing where the samples saw the
  // trunk); keys in order, so that the merged samples' order is fixed
  std::unordered_map<std::uint32_t, std::size_t> trunk_of_key;
  for (std::size_t i = 0; i < trunks.size(); ++i) trunk_of_key[trunks[i].key] = i;
  std::vector<std::uint32_t> keys;
  for (const auto& [key, list] : samples_) keys.push_back(key);
  std::sort(keys.begin(), keys.end());
  // the trunk of the key, else the narrow trunk nearest seen_at within 1 m; trunks.size() if none
  const auto trunkOf = [&](std::uint32_t key, const Eigen::Vector2d& seen_at) {
    if (const auto own = trunk_of_key.find(key); own != trunk_of_key.end()) return own->second;
    std::size_t to = trunks.size();
    double best = 1.0;
    for (std::size_t i = 0; i < narrow; ++i) {
      const double d = (trunks[i].centre - seen_at).norm();
      if (d <= best) best = d, to = i;
    }
    return to;
  };
  std::vector<std::vector<Sample>> merged(trunks.size());
  std::vector<std::vector<std::uint32_t>> merged_keys(trunks.size());
  for (std::uint32_t key : keys) {
    const std::vector<Sample>& list = samples_.at(key);
    const Eigen::Vector2d seen_at = list.back().trunk.cast<double>();
    std::size_t to = trunkOf(key, seen_at);
    if (to == trunks.size()) {
      const std::int32_t o = objectNear(seen_at);
      if (const auto grown = grown_of_object.find(o); grown != grown_of_object.end()) {
        to = grown->second;
      } else if (const auto w = wide.find(o); w != wide.end()) {
        to = trunks.size();
        trunks.push_back(w->second);
        trunks.back().centre = seen_at;
        grown_of_object[o] = to;
        merged.emplace_back(), merged_keys.emplace_back();
      }
    }
    if (to == trunks.size()) continue;
    merged[to].insert(merged[to].end(), list.begin(), list.end());
    merged_keys[to].push_back(key);
  }
  // the trunk of the key, else the narrow trunk nearest seen_at within 1 m, else a grown trunk that
  // took samples there; trunks.size() if none (the column samples and the axis's ceilings)
  const auto trunkOrGrown = [&](std::uint32_t key, const Eigen::Vector2d& seen_at) {
    const std::size_t to = trunkOf(key, seen_at);
    if (to != trunks.size()) return to;
    const auto grown = grown_of_object.find(objectNear(seen_at));
    return grown == grown_of_object.end() ? trunks.size() : grown->second;
  };
  // the column samples, by where they were taken
  std::vector<std::vector<Sample>> columns(trunks.size());
  std::vector<std::uint32_t> column_keys;
  for (const auto& [key, list] : columns_) column_keys.push_back(key);
  std::sort(column_keys.begin(), column_keys.end());
  for (std::uint32_t key : column_keys) {
    const std::vector<Sample>& list = columns_.at(key);
    const std::size_t to = trunkOrGrown(key, list.back().trunk.cast<double>());
    if (to != trunks.size()) columns[to].insert(columns[to].end(), list.begin(), list.end());
  }
  // the axis's ceilings, by where the trunk was last seen
  std::vector<std::vector<float>> ceilings(trunks.size());
  std::vector<std::uint32_t> ceiling_keys;
  for (const auto& [key, list] : ceilings_) ceiling_keys.push_back(key);
  std::sort(ceiling_keys.begin(), ceiling_keys.end());
  for (std::uint32_t key : ceiling_keys) {
    const auto record = records_.find(key);
    if (record == records_.end()) continue;
    const std::size_t to = trunkOrGrown(key, record->second.centre.cast<double>());
    if (to == trunks.size()) continue;
    const std::vector<float>& list = ceilings_.at(key);
    ceilings[to].insert(ceilings[to].end(), list.begin(), list.end());
  }
  for (std::size_t ti = 0; ti < trunks.size(); ++ti) {
    const Trunk& t = trunks[ti];
    // the samples, and apart from them the bound samples of crowns cut off by the image top
    std::vector<const Sample*> samples, bounds;
    for (const Sample& s : merged[ti]) (s.bound ? bounds : samples).push_back(&s);
    const auto judge = [&](CrownVerdict v) {
      for (std::uint32_t key : merged_keys[ti]) {
        if (const auto record = records_.find(key); record != records_.end()) record->second.verdict = v;
      }
      if (const auto record = records_.find(t.key); record != records_.end()) record->second.verdict = v;
    };
    const int min_samples = std::max(1, cfg.min_samples);
    // the min_samples-th lowest ceiling over the axis: the trunk's vertices (a narrow trunk's: a
    // grown one may hold a facade fragment beside the axis) and the crown's cap stand no higher
    double ceiling = std::numeric_limits<double>::infinity();
    if (static_cast<int>(ceilings[ti].size()) >= min_samples) {
      std::vector<float>& c = ceilings[ti];
      std::nth_element(c.begin(), c.begin() + (min_samples - 1), c.end());
      ceiling = c[static_cast<std::size_t>(min_samples - 1)];
    }
    if (std::isfinite(ceiling) && ti < narrow) {
      for (int y = t.lo.y(); y <= t.hi.y(); ++y) {
        for (int x = t.lo.x(); x <= t.hi.x(); ++x) {
          const std::int64_t j = mesh.find(CellIndex(x, y));
          if (j < 0 || objects.of[j] != t.object) continue;
          MeshVertex& m = vertices[j];
          if (m.raised() && m.recovered_height > ceiling) {
            m.recovered_height = std::max(m.sensed_height, static_cast<float>(ceiling));
            ++lowered_;
          }
        }
      }
    }
    // the farthest a camera stood from the first one's
    const auto baseline = [](const std::vector<const Sample*>& list) {
      double b = 0;
      for (const Sample* a : list) b = std::max(b, static_cast<double>((a->camera - list.front()->camera).norm()));
      return b;
    };
    double ground = std::numeric_limits<double>::quiet_NaN();  // groundAround, once needed
    double top = 0, r = 0;
    // the crown from a list of samples (top and r), or why it gives none; the radii of column samples
    // that no run bounded (0) say nothing
    const auto fromSamples = [&](const std::vector<const Sample*>& list, double radius_quantile, bool agreement) {
      if (static_cast<int>(list.size()) < min_samples) return CrownVerdict::TooFewSamples;
      // seen from far enough apart
      if (baseline(list) < cfg.min_baseline) return CrownVerdict::NoBaseline;
      ground = groundAround(t, mesh, map);  // also for the tops' agreement below
      if (!standsAboveGround(t, ground, cfg.min_trunk_height)) return CrownVerdict::Sunk;
      // A sample bounds the crown's top from above: foliage above the crown in its column (a taller
      // crown behind or before it in some frames) only lifts it. Of the groups of samples whose tops
      // lie within max_top_spread (a share of the lowest one's height above the ground around the
      // trunk, or above the trunk's sensed top where no ground is near) above the group's lowest,
      // the lowest group with min_samples samples whose cameras spread min_baseline gives the crown:
      // its median top, and the radius_quantile of its radii (a run widened by a crown beside it
      // errs only upwards).
      std::vector<const Sample*> by_top = list;
      std::stable_sort(by_top.begin(), by_top.end(), [](const Sample* a, const Sample* b) { return a->top < b->top; });
      // do the cameras of samples [first, end) of by_top lie min_baseline apart? (their bounding box
      // decides most groups; the pairs only the rest)
      const auto spread = [&](std::size_t first, std::size_t end) {
        Eigen::AlignedBox2f box;
        for (std::size_t i = first; i < end; ++i) box.extend(by_top[i]->camera);
        const Eigen::Vector2f size = box.sizes();
        if (size.maxCoeff() >= cfg.min_baseline) return true;
        if (size.norm() < cfg.min_baseline) return false;
        for (std::size_t i = first; i < end; ++i) {
          for (std::size_t j = i + 1; j < end; ++j) {
            if ((by_top[i]->camera - by_top[j]->camera).norm() >= cfg.min_baseline) return true;
          }
        }
        return false;
      };
      const double foot = std::isfinite(ground) ? ground : t.top;
      std::vector<float> tops, radii;
      // [rad] the widest angle at the trunk between two cameras of samples [first, end) of by_top,
      // once it reaches `enough` no wider
      const auto widestBearings = [&](std::size_t first, std::size_t end, double enough) {
        double widest = 0;
        for (std::size_t i = first; i < end && widest < enough; ++i)
          for (std::size_t j = i + 1; j < end && widest < enough; ++j) {
            const Eigen::Vector2f a = by_top[i]->camera - by_top[i]->trunk, b = by_top[j]->camera - by_top[j]->trunk;
            widest =
                std::max(widest, static_cast<double>(std::atan2(std::abs(a.x() * b.y() - a.y() * b.x()), a.dot(b))));
          }
        return widest;
      };
      double bearings = 0;  // [rad] the group's widest bearings, up to what radius_agreement asks
      for (std::size_t first = 0; first < by_top.size() && tops.empty(); ++first) {
        const double lowest = by_top[first]->top, reach = lowest + cfg.max_top_spread * std::max(0.0, lowest - foot);
        std::size_t end = first;
        while (end < by_top.size() && by_top[end]->top <= reach) ++end;
        if (static_cast<int>(end - first) < min_samples || !spread(first, end)) continue;
        for (std::size_t i = first; i < end; ++i) {
          tops.push_back(by_top[i]->top);
          if (!by_top[i]->column || by_top[i]->radius > 0) radii.push_back(by_top[i]->radius);
        }
        if (agreement && cfg.radius_agreement > 0) bearings = widestBearings(first, end, cfg.agreement_bearings);
      }
      if (tops.empty()) return CrownVerdict::Disagree;
      if (radii.empty()) return CrownVerdict::TooNarrow;
      std::sort(radii.begin(), radii.end());
      top = tops[tops.size() / 2], r = quantile(radii, radius_quantile);
      // radii that agree (their interquartile range within radius_agreement of their median) seen
      // from bearings agreement_bearings apart are one crown's, measured where nothing joined it:
      // their median
      const float median = quantile(radii, 0.5);
      if (agreement && cfg.radius_agreement > 0 && bearings >= cfg.agreement_bearings &&
          quantile(radii, 0.75) - quantile(radii, 0.25) <= cfg.radius_agreement * median)
        r = median;
      return r < cfg.min_radius ? CrownVerdict::TooNarrow : CrownVerdict::Raised;
    };
    const CrownVerdict verdict = fromSamples(samples, cfg.radius_quantile, true);
    // no crown from the samples: the bound samples (each a lower bound on the top) give the top's
    // cut_off_quantile and the radius_quantile of their radii
    const auto fromBounds = [&] {
      if (static_cast<int>(bounds.size()) < min_samples || baseline(bounds) < cfg.min_baseline) return false;
      if (std::isnan(ground)) ground = groundAround(t, mesh, map);
      if (!standsAboveGround(t, ground, cfg.min_trunk_height)) return false;
      std::vector<float> tops, radii;
      for (const Sample* b : bounds) tops.push_back(b->top), radii.push_back(b->radius);
      std::sort(tops.begin(), tops.end());
      std::sort(radii.begin(), radii.end());
      top = quantile(tops, cfg.cut_off_quantile);
      r = quantile(radii, cfg.radius_quantile);
      return r >= cfg.min_radius;
    };
    CrownVerdict outcome = verdict;
    if (verdict != CrownVerdict::Raised && verdict != CrownVerdict::Sunk && verdict != CrownVerdict::TooNarrow) {
      if (fromBounds()) {
        outcome = CrownVerdict::RaisedToBound;
      } else if (!columns[ti].empty()) {
        // the samples and the column samples together
        std::vector<const Sample*> all = samples;
        for (const Sample& s : columns[ti]) all.push_back(&s);
        if (fromSamples(all, cfg.column_radius_quantile, false) == CrownVerdict::Raised)
          outcome = CrownVerdict::RaisedFromColumns;
      }
    }
    if (outcome != CrownVerdict::Raised && outcome != CrownVerdict::RaisedToBound &&
        outcome != CrownVerdict::RaisedFromColumns) {
      judge(outcome);
      continue;
    }
    // a grown trunk is the tree only while all of it lies within the crown's radius of where the
    // trunk stood (half a metre more): a facade that a fragment of it grew into reaches past
    if (ti >= narrow) {
      const double half = r + 0.5;
      if ((t.lo.cast<double>() * cell - t.centre).minCoeff() < -half ||
          ((t.hi.cast<double>().array() + 1) * cell - t.centre.array()).maxCoeff() > half) {
        judge(CrownVerdict::NotApplied);
        continue;
      }
    }
    judge(outcome);
    top = std::min(top, ceiling);
    // the ground vertices (and the trunk's own) within the radius: a spherical cap topped at `top`
    const int reach = static_cast<int>(std::ceil(r / cell));
    const CellIndex c0(static_cast<int>(std::floor(t.centre.x() / cell)),
                       static_cast<int>(std::floor(t.centre.y() / cell)));
    for (int dy = -reach; dy <= reach; ++dy) {
      for (int dx = -reach; dx <= reach; ++dx) {
        const std::int64_t j = mesh.find(c0 + CellIndex(dx, dy));
        if (j < 0 || (objects.of[j] >= 0 && objects.of[j] != t.object)) continue;
        MeshVertex& m = vertices[j];
        const Eigen::Vector2d p((m.cell.x() + 0.5) * cell, (m.cell.y() + 0.5) * cell);
        const double d2 = (p - t.centre).squaredNorm();
        if (d2 > r * r) continue;
        const double cap = top - r + std::sqrt(r * r - d2);
        if (m.estimated()) {
          if (cfg.cap_bounds_trunk && outcome == CrownVerdict::Raised && objects.of[j] == t.object &&
              m.recovered_height > cap) {
            m.recovered_height = std::max(m.sensed_height, static_cast<float>(cap));
            ++lowered_by_cap_;
          }
          continue;  // its own estimates stand
        }
        if (cfg.sky_guard && sky_through && sky_through(p.x(), p.y(), top - r, cap)) continue;
        raised += raiseUnderCrown(m, static_cast<float>(cap));
      }
    }
  }
  return raised;
}

}  // namespace terrain
