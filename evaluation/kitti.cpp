#include "evaluation/kitti.hpp"

#include "evaluation/baselines.hpp"
#include "evaluation/metrics.hpp"
#include "rig/kitti.hpp"

#include <chrono>
#include <cstring>
#include <map>
#include <string>
#include <utility>

namespace terrain::eval {

using nlohmann::json;

namespace {

// One scan segmented once by a segmenter: per point the GMRF's labels after the per-point step, the
// same voxel labels without it and the histogram's rough classes, and the time the first took [ms].
struct ScanLabels {
  std::vector<std::uint8_t> points, voxels, rough;
  double milliseconds = 0;
};
ScanLabels labelScan(ScanSegmenter& segmenter, const std::vector<Point3>& points) {
  ScanLabels out;
  const auto t0 = std::chrono::steady_clock::now();
  out.points = segmenter.segment(points);
  out.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  GroundSegmentationConfig as_voxels = segmenter.config();
  as_voxels.point_rise = 0;
  const auto& map = segmenter.map();
  out.voxels = labelScanPoints(map, points, segmenter.voxelOf(), segmenter.result().refined, as_voxels);
  out.rough = labelScanPoints(map, points, segmenter.voxelOf(), segmenter.result().rough, as_voxels);
  return out;
}

GroundSegmentationConfig withSolver(GroundSegmentationConfig config, GroundSegmentationConfig::Solver solver) {
  config.solver = solver;
  return config;
}

}  // namespace

json kittiConfusion(const std::vector<Point3>& points, const std::vector<std::uint16_t>& labels,
                    const std::vector<std::uint8_t>& ground) {
  struct Count {
    std::uint64_t points = 0, ground = 0;
  };
  std::map<std::string, Count> by_class;
  static const char* const kBands[] = {"0-10", "10-20", "20-30", "30-50", "50+"};
  struct Band {
    std::uint64_t points = 0, false_ground = 0, missed_ground = 0;
  };
  Band bands[5];
  for (std::size_t i = 0; i < points.size(); ++i) {
    Count& c = by_class[rig::kittiClassName(labels[i])];
    ++c.points;
    c.ground += ground[i] != 0;
    if (rig::isKittiIgnored(labels[i])) continue;
    const double d = points[i].head<2>().norm();
    Band& b = bands[d < 10 ? 0 : d < 20 ? 1 : d < 30 ? 2 : d < 50 ? 3 : 4];
    ++b.points;
    const bool truth = rig::isKittiGround(labels[i]);
    b.false_ground += !truth && ground[i];
    b.missed_ground += truth && !ground[i];
  }
  json j;
  for (const auto& [name, c] : by_class) j["by_class"][name] = {{"points", c.points}, {"labelled_ground", c.ground}};
  for (int k = 0; k < 5; ++k) {
    j["by_distance"][kBands[k]] = {{"points", bands[k].points},
                                   {"false_ground", bands[k].false_ground},
                                   {"missed_ground", bands[k].missed_ground}};
  }
  return j;
}

std::string kittiVerdictPly(const std::vector<Point3>& points, const std::vector<std::uint16_t>& labels,
                            const std::vector<std::uint8_t>& ground) {
  std::string out =
      "ply\nformat binary_little_endian 1.0\ncomment class (SemanticKITTI, learning order), ground label, verdict (0 "
      "non-ground right, 1 ground right, 2 false ground, 3 missed ground, 4 unscored)\nelement vertex " +
      std::to_string(points.size()) +
      "\nproperty float x\nproperty float y\nproperty float z\nproperty ushort class\n"
      "property uchar ground\nproperty uchar verdict\nend_header\n";
  const std::size_t header = out.size();
  constexpr std::size_t kRecord = 3 * sizeof(float) + sizeof(std::uint16_t) + 2;
  out.resize(header + kRecord * points.size());
  char* p = out.data() + header;
  for (std::size_t i = 0; i < points.size(); ++i, p += kRecord) {
    const float xyz[3] = {float(points[i].x()), float(points[i].y()), float(points[i].z())};
    const std::uint16_t cls = labels[i];
    const bool truth = rig::isKittiGround(labels[i]);
    const std::uint8_t marks[2] = {ground[i], std::uint8_t(rig::isKittiIgnored(labels[i]) ? 4
                                                           : ground[i]                    ? (truth ? 1 : 2)
                                                                                          : (truth ? 3 : 0))};
    std::memcpy(p, xyz, sizeof xyz);  // the PLY is little-endian, as every machine this builds on
    std::memcpy(p + sizeof xyz, &cls, sizeof cls);
    std::memcpy(p + sizeof xyz + sizeof cls, marks, sizeof marks);
  }
  return out;
}

KittiScorer::KittiScorer(const VoxelMapConfig& voxels, const GroundSegmentationConfig& ground, double sensor_height)
    : ground_(ground),
      sensor_height_(sensor_height),
      icm_(voxels, withSolver(ground, GroundSegmentationConfig::Solver::Icm)),
      mincut_(voxels, withSolver(ground, GroundSegmentationConfig::Solver::MinCut)) {}

json KittiScorer::score(const std::vector<Point3>& points, const std::vector<std::uint16_t>& labels) {
  std::vector<bool> truth(points.size()), skip(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    truth[i] = rig::isKittiGround(labels[i]);
    skip[i] = rig::isKittiIgnored(labels[i]);
  }
  auto score = [&](const std::vector<std::uint8_t>& pred) {
    const BinaryScores s = binaryScores(std::vector<bool>(pred.begin(), pred.end()), truth, skip);
    return json{{"precision", s.precision}, {"recall", s.recall}, {"f1", s.f1}, {"iou", s.iou}};
  };
  json j;
  j["points"] = points.size();
  // each solver once: its labels per point, its voxel labels before the per-point step (the GMRF's
  // own share) and, of the configured one, where it errs and the histogram's rough classes (they do
  // not depend on the solver)
  const ScanLabels icm = labelScan(icm_, points);
  const ScanLabels cut = labelScan(mincut_, points);
  for (const auto& [name, s] : {std::pair<const char*, const ScanLabels*>{"gmrf_icm", &icm}, {"gmrf_mincut", &cut}}) {
    j[name] = score(s->points);
    j[name]["time_ms"] = s->milliseconds;
    j["voxel_labels"][name] = score(s->voxels);
  }
  const bool by_icm = ground_.solver == GroundSegmentationConfig::Solver::Icm;
  const ScanLabels& configured = by_icm ? icm : cut;
  ground_of_last_ = configured.points;
  j["confusion"] = kittiConfusion(points, labels, configured.points);
  j["confusion"]["method"] = by_icm ? "gmrf_icm" : "gmrf_mincut";
  j["histogram"] = score(configured.rough);
  j["fixed_band"] = score(groundByFixedBand(points, {Point3(0, 0, -sensor_height_)}, ground_.delta));
  j["ransac_plane"] = score(groundByRansacPlane(points, 0.2));
  j["morphological_filter"] = score(groundByMorphologicalFilter(points, MorphologicalFilterConfig{}));
  return j;
}

}  // namespace terrain::eval
