#include "evaluation/report.hpp"

#include "core/camera_model.hpp"
#include "evaluation/baselines.hpp"
#include "evaluation/metrics.hpp"
#include "evaluation/scoring.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

namespace terrain::eval {

using nlohmann::json;

namespace {

json errorJson(const ErrorStats& e) {
  return {{"mae_m", e.mae}, {"rmse_m", e.rmse}, {"bias_m", e.bias}, {"variance_m2", e.variance}, {"cells", e.count}};
}

json binaryJson(const BinaryScores& b) {
  return {{"precision", b.precision},
          {"recall", b.recall},
          {"f1", b.f1},
          {"iou", b.iou},
          {"tp", b.tp},
          {"fp", b.fp},
          {"fn", b.fn},
          {"tn", b.tn}};
}

// per voxel and per point (each voxel weighted by the true points in it)
json segmentationJson(const VoxelMap& map, const std::vector<std::uint8_t>& ground, const VoxelTruth& truth) {
  const SegmentationScores voxel = scoreVoxels(map, ground, truth);
  std::size_t tp = 0, fp = 0, fn = 0, tn = 0;
  for (std::size_t i = 0; i < map.size() && i < ground.size(); ++i) {
    const auto [g, n] = truth.votes(map.voxels()[i].index);
    if (ground[i])
      tp += g, fp += n;
    else
      fn += g, tn += n;
  }
  json j = binaryJson(voxel.scores);
  j["per_point"] = binaryJson(binaryScores(tp, fp, fn, tn));
  return j;
}

std::vector<Point3> voxelPoints(const VoxelMap& map) {
  std::vector<Point3> pts;
  pts.reserve(map.size());
  for (const auto& v : map.voxels()) {
    pts.emplace_back((v.index.x() + 0.5) * map.voxelSize(), (v.index.y() + 0.5) * map.voxelSize(), v.height);
  }
  return pts;
}

}  // namespace

void addFrameTruth(RunTruth& truth, const rig::RigFrame& frame, const RigCalibration& calibration, int camera_every) {
  if (!frame.truth) return;
  truth.voxels.add(frame, calibration.vehicle_from_lidar);
  for (const auto& p : frame.truth->poses) truth.path.push_back(p.world_from_vehicle.translation());
  if (truth.camera_stride == 0) truth.camera_stride = camera_every;
  if (truth.camera_stride > 0 && frame.sensors.index % truth.camera_stride == 0) {
    for (const CameraImage& image : frame.sensors.images) {
      const auto t = std::find_if(frame.truth->cameras.begin(), frame.truth->cameras.end(),
                                  [&](const rig::CameraTruth& c) { return c.camera == image.camera; });
      if (t == frame.truth->cameras.end() || t->segmentation.empty()) continue;
      if (image.camera < 0 || image.camera >= static_cast<int>(calibration.cameras.size())) continue;
      CameraTruthFrame c;
      c.frame = frame.sensors.index;
      c.camera = image.camera;
      c.rgb = image.rgb;
      c.segmentation = t->segmentation;
      c.world_from_camera =
          interpolatePose(frame.truth->poses, image.time) * calibration.cameras[image.camera].vehicle_from_camera;
      truth.cameras.push_back(std::move(c));
    }
    if (keptFrameCount(truth) > kMaxCameraFrames) {
      // keep the frames on the doubled stride
      truth.camera_stride *= 2;
      std::vector<CameraTruthFrame> kept;
      for (auto& k : truth.cameras) {
        if (k.frame % truth.camera_stride == 0) kept.push_back(std::move(k));
      }
      truth.cameras = std::move(kept);
    }
  }
}

std::size_t keptFrameCount(const RunTruth& truth) {
  std::set<int> frames;
  for (const auto& c : truth.cameras) frames.insert(c.frame);
  return frames.size();
}

BoundaryCoverage boundaryCoverage(const TerrainMesh& mesh, const std::vector<RoofCell>& roof, double cell,
                                  const sim::World& world, const CameraIntrinsics& k, const CameraTruthFrame& f,
                                  int tolerance) {
  BoundaryCoverage out;
  const cv::Mat& seg = f.segmentation;
  cv::Mat boundary(seg.size(), CV_8UC1, cv::Scalar(0));
  // the depth of the surface a pixel looks at, along its ray through the true world; infinite for
  // the sky (the robot's own geoms, which the caster leaves out, are nearer than anything)
  const Point3 centre = f.world_from_camera.translation();
  const auto depthAt = [&](int u, int v) {
    const int g = seg.at<std::uint16_t>(v, u) - 1;
    if (g < 0) return std::numeric_limits<double>::infinity();
    if (world.geomClass(g) == scenes::GeomClass::Robot) return 0.0;
    const sim::RayHit hit = world.castRay(centre, f.world_from_camera.linear() * pixelRay(k, Pixel(u + 0.5, v + 0.5)));
    return hit.distance < 0 ? std::numeric_limits<double>::infinity() : hit.distance;
  };
  for (int v = 1; v < seg.rows; ++v) {
    for (int u = 0; u < seg.cols; ++u) {
      const int g = seg.at<std::uint16_t>(v, u) - 1, above = seg.at<std::uint16_t>(v - 1, u) - 1;
      if (!scenes::isObjectClass(world.geomClass(g)) || g == above) continue;
      // a nearer surface above hides the object's top: that edge is the other's lower one
      if (above >= 0 && depthAt(u, v - 1) <= depthAt(u, v)) {
        ++out.occluded_pixels;
        continue;
      }
      boundary.at<std::uint8_t>(v, u) = 255;
    }
  }
  out.boundary_pixels = static_cast<std::size_t>(cv::countNonZero(boundary));
  if (out.boundary_pixels == 0) return out;
  const Pose camera_from_world = f.world_from_camera.inverse();
  cv::Mat before(seg.size(), CV_8UC1, cv::Scalar(0)), after = before.clone();
  for (const auto& m : mesh.vertices()) {
    const double x = (m.cell.x() + 0.5) * cell, y = (m.cell.y() + 0.5) * cell;
    for (auto [height, target] :
         {std::pair{static_cast<double>(m.sensed_height), &before}, {static_cast<double>(m.height()), &after}}) {
      const auto px = project(k, camera_from_world * Point3(x, y, height));
      if (px) target->at<std::uint8_t>(static_cast<int>(px->y()), static_cast<int>(px->x())) = 255;
    }
  }
  for (const auto& r : roof) {
    const auto px =
        project(k, camera_from_world * Point3((r.cell.x() + 0.5) * cell, (r.cell.y() + 0.5) * cell, r.height));
    if (px) after.at<std::uint8_t>(static_cast<int>(px->y()), static_cast<int>(px->x())) = 255;
  }
  const cv::Mat grow = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * tolerance + 1, 2 * tolerance + 1));
  cv::dilate(before, before, grow);
  cv::dilate(after, after, grow);
  out.before = cv::countNonZero(boundary & before) / static_cast<double>(out.boundary_pixels);
  out.after = cv::countNonZero(boundary & after) / static_cast<double>(out.boundary_pixels);
  return out;
}

CoverageScores scoreBoundaryCoverage(const TerrainMesh& mesh, const std::vector<RoofCell>& roof, double voxel_size,
                                     const sim::World& world, const RigCalibration& calibration,
                                     const std::vector<CameraTruthFrame>& frames, int tolerance) {
  CoverageScores out;
  for (const auto& f : frames) {
    const BoundaryCoverage b =
        boundaryCoverage(mesh, roof, voxel_size, world, intrinsicsOf(calibration, f), f, tolerance);
    out.images.push_back({f.frame, f.camera, b});
    for (CoverageSum* k : {&out.all, &out.by_camera[f.camera]}) {
      k->before += b.before * b.boundary_pixels;
      k->after += b.after * b.boundary_pixels;
      k->pixels += b.boundary_pixels;
      k->occluded += b.occluded_pixels;
      ++k->images;
    }
  }
  return out;
}

void TopCount::add(double error_before, double error_after, double tolerance) {
  ++seen;
  before += std::abs(error_before) <= tolerance, after += std::abs(error_after) <= tolerance;
  high_before += error_before > tolerance, high_after += error_after > tolerance;
}

TopScores scoreObjectTops(const HeightScores& heights, const std::map<std::string, TopSightings>& seen,
                          const std::vector<CrownRecord>& crowns, const sim::World& world) {
  TopScores out;
  // the trunk records within 1.5 m of each tree's centre
  std::map<std::string, TreeCrown> crown_of;
  for (const auto& o : world.truth().objects) {
    if (o.object_class == scenes::GeomClass::Building || o.footprint.empty()) continue;
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& q : o.footprint) c += q;
    c /= static_cast<double>(o.footprint.size());
    for (const auto& rec : crowns) {
      if ((rec.centre.cast<double>() - c).norm() > 1.5) continue;
      TreeCrown& tc = crown_of[o.id];
      ++tc.records;
      for (std::size_t k = 0; k < kCrownOutcomes; ++k) tc.outcomes[k] += rec.outcomes[k];
      tc.verdict = std::max(tc.verdict, rec.verdict);
    }
  }
  std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> errors;
  out.by_class = {{"building", {}}, {"tree", {}}};
  for (const auto& [id, t] : heights.tops) {
    const auto it = seen.find(id);
    if (it == seen.end()) continue;
    TopScore& o = out.objects[id];
    o.top = t;
    o.sightings = it->second;
    o.tolerance = topTolerance(t);
    o.error_before = std::isfinite(t.sensed) ? t.sensed - t.top : -(t.top - t.base);
    o.error_after = std::isfinite(t.recovered) ? t.recovered - t.top : o.error_before;
    if (!t.building) {
      if (const auto tc = crown_of.find(id); tc != crown_of.end()) o.crown = tc->second;
    }
    const std::string kind = t.building ? "building" : "tree";
    ClassTops& s = out.by_class[kind];
    s.all.add(o.error_before, o.error_after, o.tolerance);
    if (o.sightings.with_lower_part > 0) s.with_lower_part.add(o.error_before, o.error_after, o.tolerance);
    errors[kind].first.push_back(o.error_before), errors[kind].second.push_back(o.error_after);
  }
  for (auto& [kind, s] : out.by_class)
    s.before = errorStats(errors[kind].first), s.after = errorStats(errors[kind].second);
  return out;
}

const CameraIntrinsics& intrinsicsOf(const RigCalibration& calibration, const CameraTruthFrame& frame) {
  return calibration.cameras.at(static_cast<std::size_t>(frame.camera)).intrinsics;
}

std::map<std::string, TopSightings> topSeenFrames(const sim::World& world, const RigCalibration& calibration,
                                                  const std::vector<CameraTruthFrame>& images) {
  // geom -> its object
  std::map<int, const scenes::ObjectTruth*> object_of;
  for (const auto& o : world.truth().objects) {
    for (const auto& g : o.geoms) object_of[mj_name2id(world.model(), mjOBJ_GEOM, g.c_str())] = &o;
  }
  // the objects whose top (and lower part) each frame's cameras saw
  std::map<int, std::pair<std::set<std::string>, std::set<std::string>>> by_frame;
  for (const auto& f : images) {
    const CameraIntrinsics& k = intrinsicsOf(calibration, f);
    const cv::Mat& seg = f.segmentation;
    const Eigen::Vector3d origin = f.world_from_camera.translation();
    // the height of the point the pixel looks at if it lies on geom g; NaN if another geom hides it
    const auto heightSeen = [&](int u, int v, int g) {
      const Eigen::Vector3d dir = f.world_from_camera.linear() * pixelRay(k, Pixel(u + 0.5, v + 0.5));
      const sim::RayHit hit = world.castRay(origin, dir);
      return hit.geom == g ? origin.z() + hit.distance * dir.z() : std::numeric_limits<double>::quiet_NaN();
    };
    auto& [tops, bases] = by_frame[f.frame];
    for (int v = 0; v < seg.rows; ++v) {
      for (int u = 0; u < seg.cols; ++u) {
        const int g = seg.at<std::uint16_t>(v, u) - 1;
        const bool top_edge = v > 0 && g != seg.at<std::uint16_t>(v - 1, u) - 1;
        const bool bottom_edge = v + 1 < seg.rows && g != seg.at<std::uint16_t>(v + 1, u) - 1;
        if (!top_edge && !bottom_edge) continue;
        const auto it = object_of.find(g);
        if (it == object_of.end()) continue;
        const scenes::ObjectTruth& o = *it->second;
        // a top boundary pixel looking at the object's top
        if (top_edge && !tops.count(o.id) &&
            heightSeen(u, v, g) >= o.top_height - std::max(1.0, 0.15 * (o.top_height - o.base_height)))
          tops.insert(o.id);
        // a bottom boundary pixel looking at the object's lower part
        if (bottom_edge && !bases.count(o.id) && heightSeen(u, v, g) <= o.base_height + kLowerPart) bases.insert(o.id);
      }
    }
  }
  std::map<std::string, TopSightings> out;
  for (const auto& [frame, seen] : by_frame) {
    for (const auto& id : seen.first) {
      TopSightings& s = out[id];
      ++s.top;
      s.with_lower_part += seen.second.count(id) > 0;
    }
  }
  return out;
}

json poseJson(const Pipeline& pipeline, const RunTruth& truth) {
  // the true vehicle pose at each kept camera frame (its exposure is at the sweep's start, the
  // record's time) against the pipeline's final pose then
  std::map<int, const FrameRecord*> record_of;
  for (const auto& rec : pipeline.records()) record_of[rec.frame] = &rec;
  std::vector<double> horizontal, vertical, heading, pitch, roll;
  std::set<int> scored;  // a frame once, whichever of its cameras
  for (const auto& c : truth.cameras) {
    const auto it = record_of.find(c.frame);
    if (it == record_of.end() || !scored.insert(c.frame).second) continue;
    const Pose camera_to_vehicle = pipeline.calibration().cameras.at(c.camera).vehicle_from_camera.inverse();
    Pose estimated = Pose::Identity();
    estimated.linear() = it->second->attitude.toRotationMatrix();
    estimated.translation() = it->second->position;
    const PoseError e = poseError(estimated, c.world_from_camera * camera_to_vehicle);
    horizontal.push_back(e.horizontal), vertical.push_back(e.vertical);
    constexpr double kToDegrees = 180 / M_PI;
    heading.push_back(e.heading * kToDegrees), pitch.push_back(e.pitch * kToDegrees),
        roll.push_back(e.roll * kToDegrees);
  }
  const auto stats = [](const std::vector<double>& v) {
    return json{{"median", percentiles(v).median}, {"max", v.empty() ? 0.0 : *std::max_element(v.begin(), v.end())}};
  };
  return {{"frames", horizontal.size()},         {"horizontal_error_m", stats(horizontal)},
          {"vertical_error_m", stats(vertical)}, {"heading_error_deg", stats(heading)},
          {"pitch_error_deg", stats(pitch)},     {"roll_error_deg", stats(roll)}};
}

double sensingPeriodMs(const std::vector<FrameRecord>& records) {
  std::vector<double> starts;
  for (const auto& r : records) starts.push_back(r.time);
  std::sort(starts.begin(), starts.end());
  std::vector<double> gaps;
  for (std::size_t i = 1; i < starts.size(); ++i) gaps.push_back(1000.0 * (starts[i] - starts[i - 1]));
  return gaps.empty() ? 0.0 : percentiles(gaps).median;
}

json timingJson(const std::vector<FrameRecord>& records) {
  std::map<std::string, std::vector<double>> stages;
  for (const auto& r : records) {
    stages["pose"].push_back(r.pose_ms);
    stages["voxel_map"].push_back(r.voxel_ms);
    stages["terrain_mesh"].push_back(r.mesh_ms);
    stages["ground_segmentation"].push_back(r.segmentation_ms);
    stages["boundary_detection"].push_back(r.boundary_ms);
    stages["boundary_estimation"].push_back(r.estimation_ms);
    stages["total"].push_back(r.total_ms);
  }
  json j;
  for (const auto& [name, values] : stages) {
    const Percentiles p = percentiles(values);
    j[name] = {{"median_ms", p.median}, {"p95_ms", p.p95}};
  }
  const double period = sensingPeriodMs(records);
  std::size_t over = 0;
  if (period > 0) {
    for (double t : stages["total"]) over += t > period;
  }
  j["sensing_period_ms"] = period;
  j["frames_over_sensing_period"] = over;
  return j;
}

json evaluateRun(const Pipeline& pipeline, const RunTruth& truth, const sim::World& world,
                 const EvaluationOptions& options) {
  json r;
  const VoxelMap& map = pipeline.map();
  const auto& seg = pipeline.segmentation();
  r["frames"] = pipeline.records().size();
  r["voxels"] = map.size();
  r["pose"] = poseJson(pipeline, truth);
  // what the truth leaves unscored
  json truth_warnings = json::array();
  if (const std::vector<std::string> loose = world.unclassifiedGeoms(); !loose.empty()) {
    std::string names;
    for (std::size_t i = 0; i < std::min<std::size_t>(5, loose.size()); ++i) names += (i ? ", " : "") + loose[i];
    truth_warnings.push_back(std::to_string(loose.size()) +
                             " scene geom(s) belong to no object of the truth sidecar and are not the terrain (" +
                             names + (loose.size() > 5 ? ", ..." : "") +
                             "): their points and cells are scored as neither ground nor object");
  }

  // ground segmentation: histogram, both GMRF solvers, the baselines
  GroundSegmentationConfig other = pipeline.config().ground;
  const bool icm = other.solver == GroundSegmentationConfig::Solver::Icm;
  other.solver = icm ? GroundSegmentationConfig::Solver::MinCut : GroundSegmentationConfig::Solver::Icm;
  const SegmentationResult alternative = segmentGroundLabels(map, other);
  const SegmentationResult& by_icm = icm ? seg : alternative;
  const SegmentationResult& by_cut = icm ? alternative : seg;
  json& g = r["ground_segmentation"];
  g["histogram"] = segmentationJson(map, seg.rough, truth.voxels);
  g["gmrf_icm"] = segmentationJson(map, by_icm.refined, truth.voxels);
  g["gmrf_icm"]["energy"] = by_icm.energy_refined;
  g["gmrf_mincut"] = segmentationJson(map, by_cut.refined, truth.voxels);
  g["gmrf_mincut"]["energy"] = by_cut.energy_refined;
  g["histogram"]["energy"] = seg.energy_rough;
  if (options.ground_baselines) {
    const std::vector<Point3> pts = voxelPoints(map);
    std::vector<Point3> vehicle;
    for (const auto& rec : pipeline.records()) vehicle.push_back(rec.position);
    g["fixed_band"] =
        segmentationJson(map, groundByFixedBand(pts, vehicle, pipeline.config().ground.delta), truth.voxels);
    g["ransac_plane"] = segmentationJson(map, groundByRansacPlane(pts, 0.2), truth.voxels);
    g["morphological_filter"] =
        segmentationJson(map, groundByMorphologicalFilter(pts, MorphologicalFilterConfig{}), truth.voxels);
  } else {
    g["baselines_skipped"] = "not asked for (--no-baselines)";
  }

  // heights of object vertices, before and after recovery
  const HeightScores h = scoreHeights(pipeline.mesh(), map, world, truth.path, pipeline.roofCells());
  json& hr = r["height_recovery"];
  hr["before"] = errorJson(h.before);
  hr["after"] = errorJson(h.after);
  hr["estimated_cells"] = {{"before", errorJson(h.seen_before)}, {"after", errorJson(h.seen_after)}};
  if (h.after.count == 0) {
    truth_warnings.push_back(
        world.truth().objects.empty()
            ? "the truth sidecar lists no objects: object heights are not scored (0 cells)"
            : "no cell of the map lies under an object of the truth: object heights are not scored (0 cells)");
  }
  hr["raised_terrain_cells"] = h.raised_terrain_cells;
  hr["raised_terrain_cells_by_step"] = {
      {"crown_completion", h.raised_terrain_ground_cells},
      {"boundary_estimation", h.raised_terrain_cells - h.raised_terrain_ground_cells}};
  hr["raised_edge_cells"] = h.raised_edge_cells;
  for (const auto& [view, e] : h.by_view) {
    hr["by_camera_view"][view] = {
        {"before", errorJson(e.first)}, {"after", errorJson(e.second)}, {"raised_cells", h.raised_by_view.at(view)}};
  }
  for (const auto& [band, e] : h.by_band)
    hr["by_distance"][band] = {{"before", errorJson(e.first)}, {"after", errorJson(e.second)}};
  for (const auto& [id, e] : h.by_object) {
    hr["by_object"][id] = {{"before", errorJson(e.first)},
                           {"after", errorJson(e.second)},
                           {"cells_in_camera_view", h.in_view_by_object.at(id)}};
  }
  for (const auto& [kind, e] : h.by_kind)
    hr["by_kind"][kind] = {{"before", errorJson(e.first)}, {"after", errorJson(e.second)}};
  hr["object_cells_sensed_as_terrain"] = h.sensed_as_terrain;
  // the tops of the objects whose top the camera saw: do they stand at their real height?
  {
    const TopScores ts =
        scoreObjectTops(h, topSeenFrames(world, pipeline.calibration(), truth.cameras), pipeline.crownRecords(), world);
    json& tops = hr["object_tops"];
    json& list = tops["list"] = json::object();
    for (const auto& [id, o] : ts.objects) {
      json outcomes = json::object();
      for (std::size_t k = 0; k < kEstimateOutcomes; ++k)
        outcomes[outcomeName(static_cast<EstimateOutcome>(k))] = o.top.outcomes[k];
      list[id] = {{"class", o.top.building ? "building" : "tree"},
                  {"true_top_m", o.top.top},
                  {"sensed_top_m", o.top.sensed},
                  {"recovered_top_m", o.top.recovered},
                  {"error_m", o.error_after},
                  {"tolerance_m", o.tolerance},
                  {"frames_top_seen", o.sightings.top},
                  {"frames_lower_part_seen_with_top", o.sightings.with_lower_part},
                  {"cells", o.top.cells},
                  {"estimation_outcomes", outcomes}};
      if (!o.top.building) {
        json& crown = list[id]["crown"];
        if (o.crown) {
          json counts = json::object();
          for (std::size_t k = 0; k < kCrownOutcomes; ++k)
            counts[outcomeName(static_cast<CrownOutcome>(k))] = o.crown->outcomes[k];
          crown = {
              {"trunk_records", o.crown->records}, {"outcomes", counts}, {"verdict", verdictName(o.crown->verdict)}};
        }
      }
    }
    for (const auto& [kind, s] : ts.by_class) {
      const TopCount& a = s.all;
      const TopCount& w = s.with_lower_part;
      tops[kind] = {{"top_seen", a.seen},
                    {"at_height_before", a.before},
                    {"at_height_after", a.after},
                    {"too_high_before", a.high_before},
                    {"too_high_after", a.high_after},
                    {"before", errorJson(s.before)},
                    {"after", errorJson(s.after)},
                    {"lower_part_seen_with_top",
                     {{"objects", w.seen},
                      {"at_height_before", w.before},
                      {"at_height_after", w.after},
                      {"too_high_before", w.high_before},
                      {"too_high_after", w.high_after}}}};
    }
    tops["frames"] = keptFrameCount(truth);
  }
  // roofs of completed building footprints
  const RoofScores roof = scoreRoofCells(pipeline.roofCells(), map.voxelSize(), world);
  hr["footprints"] = {{"completed", pipeline.footprints().size()},   {"roof_cells", roof.cells},
                      {"object_cells", roof.object_cells},           {"building_cells", roof.building_cells},
                      {"wrongly_filled_cells", roof.wrongly_filled}, {"on_objects", errorJson(roof.on_objects)}};
  // ground vertices raised under tree crowns (crown completion), and vertices whose estimates the
  // parallax test held back (an edge behind them formed their skyline)
  std::size_t under_crowns = 0, parallax = 0;
  for (const auto& m : pipeline.mesh().vertices()) {
    under_crowns += m.raised() && map.voxels()[m.top_voxel].label == VoxelLabel::Ground;
    parallax += m.parallax;
  }
  hr["crown_ground_vertices"] = under_crowns;
  hr["crown_hull"] = {{"raised_vertices", pipeline.hullRaised()},
                      {"columns", pipeline.hullColumns()},
                      {"crown_voxels", pipeline.hullCrownVoxels()}};
  // raised vertices the sky's ceiling lowered (free space), and how many vertices have a ceiling
  std::size_t with_ceiling = 0;
  for (const auto& m : pipeline.mesh().vertices()) with_ceiling += std::isfinite(m.ceiling);
  hr["sky_ceiling"] = {{"lowered_vertices", pipeline.skyLowered()}, {"vertices_with_ceiling", with_ceiling}};
  hr["parallax_vertices"] = parallax;
  json& list = hr["footprints"]["list"] = json::array();
  for (const auto& f : pipeline.footprints()) {
    json corners = json::array();
    for (const auto& c : f.corners) corners.push_back({c.x(), c.y()});
    json entry = {{"corners_m", corners},
                  {"roof_height_m", f.roof_height},
                  {"wall_vertices", f.wall_vertices},
                  {"raised_vertices", f.raised_vertices}};
    // the true building under it
    const FootprintMatch match = matchFootprint(f, world, map.voxelSize());
    if (!match.object.empty()) {
      entry["true_building"] = match.object;
      entry["true_top_m"] = match.true_top;
      entry["roof_error_m"] = f.roof_height - match.true_top;
      entry["footprint_iou"] = match.iou;
    }
    list.push_back(entry);
  }

  // height baselines on the height map: sensed only, inpainted, recovered
  r["height_baselines"] = json::object();
  {
    const HeightBaselineScores hb = scoreHeightBaselines(pipeline.mesh(), pipeline.roofCells(), map.voxelSize(), world);
    json& out = r["height_baselines"];
    if (hb.status == HeightBaselineScores::Status::TooWide) {
      out["skipped"] = "the mesh spans " + std::to_string(hb.span) + " cells, more than " +
                       std::to_string(kMaxHeightMapCells) + ": no height map over its extent";
    } else if (hb.status == HeightBaselineScores::Status::Scored) {
      const auto entry = [](const HeightMapError& e) {
        json j = errorJson(e.error);
        j["coverage"] = e.coverage;
        return j;
      };
      out["sensed_only"] = entry(hb.sensed_only);
      out["inpainting"] = entry(hb.inpainting);
      out["boundary_estimation"] = entry(hb.recovered);
      out["object_cells"] = hb.object_cells;
    }
  }

  // boundary coverage over the kept camera images, overall and per camera
  const CoverageScores coverage = scoreBoundaryCoverage(pipeline.mesh(), pipeline.roofCells(), map.voxelSize(), world,
                                                        pipeline.calibration(), truth.cameras, 3);
  const auto& cameras = pipeline.calibration().cameras;
  json frames = json::array();
  for (const ImageCoverage& c : coverage.images) {
    frames.push_back({{"frame", c.frame},
                      {"camera", cameras.at(c.camera).name},
                      {"before", c.coverage.before},
                      {"after", c.coverage.after},
                      {"boundary_pixels", c.coverage.boundary_pixels},
                      {"occluded_pixels", c.coverage.occluded_pixels}});
  }
  r["boundary_coverage"] = coverage.all.meanAfter();
  r["boundary_coverage_before"] = coverage.all.meanBefore();
  r["boundary_coverage_frames"] = frames;
  json& by_camera = r["boundary_coverage_by_camera"] = json::object();
  for (const auto& [camera, k] : coverage.by_camera) {
    by_camera[cameras.at(camera).name] = {{"after", k.meanAfter()},
                                          {"before", k.meanBefore()},
                                          {"boundary_pixels", k.pixels},
                                          {"occluded_pixels", k.occluded},
                                          {"images", k.images}};
  }
  r["cameras"] = json::array();
  for (const auto& c : cameras) r["cameras"].push_back(c.name);
  r["timing"] = timingJson(pipeline.records());
  r["truth_warnings"] = truth_warnings;
  return r;
}

std::map<std::string, double> flattenMetrics(const json& report) {
  std::map<std::string, double> out;
  std::function<void(const json&, const std::string&)> walk = [&](const json& j, const std::string& prefix) {
    if (j.is_object()) {
      for (auto it = j.begin(); it != j.end(); ++it)
        walk(it.value(), prefix.empty() ? it.key() : prefix + "." + it.key());
    } else if (j.is_number()) {
      out[prefix] = j.get<double>();
    }
  };
  walk(report, "");
  return out;
}

}  // namespace terrain::eval
