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

// One scan segmented once: per point the GMRF's labels after the per-point step, the same voxel
// labels without it and the histogram's rough classes, and the time the first took [ms].
struct ScanLabels {
  std::vector<std::uint8_t> points, voxels, rough;
  double milliseconds = 0;
};
ScanLabels labelScan(const std::vector<Point3>& points, const VoxelMapConfig& voxels,
                     const GroundSegmentationConfig& ground, bool voxel_labels_too) {
  ScanLabels out;
  const auto t0 = std::chrono::steady_clock::now();
  VoxelMap map(voxels);
  std::vector<std::uint32_t> voxel_of;
  map.insert(points, 0, nullptr, &voxel_of);
  const SegmentationResult result = segmentGroundLabels(map, ground);
  out.points = labelScanPoints(map, points, voxel_of, result.refined, ground);
  out.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (voxel_labels_too) {
    GroundSegmentationConfig as_voxels = ground;
    as_voxels.point_rise = 0;
    out.voxels = labelScanPoints(map, points, voxel_of, result.refined, as_voxels);
    out.rough = labelScanPoints(map, points, voxel_of, result.rough, as_voxels);
  }
  return out;
}

}  // namespace

std::vector<std::uint8_t> segmentScan(const std::vector<Point3>& points, const VoxelMapConfig& voxels,
                                      const GroundSegmentationConfig& ground, double* milliseconds) {
  ScanLabels labels = labelScan(points, voxels, ground, false);
  if (milliseconds) *milliseconds = labels.milliseconds;
  return std::move(labels.points);
}

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

json scoreKittiScan(const std::vector<Point3>& points, const std::vector<std::uint16_t>& labels,
                    const VoxelMapConfig& voxels, const GroundSegmentationConfig& ground, double sensor_height) {
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
  GroundSegmentationConfig g = ground;
  g.solver = GroundSegmentationConfig::Solver::Icm;
  const ScanLabels icm = labelScan(points, voxels, g, true);
  g.solver = GroundSegmentationConfig::Solver::MinCut;
  const ScanLabels cut = labelScan(points, voxels, g, true);
  for (const auto& [name, s] : {std::pair<const char*, const ScanLabels*>{"gmrf_icm", &icm}, {"gmrf_mincut", &cut}}) {
    j[name] = score(s->points);
    j[name]["time_ms"] = s->milliseconds;
    j["voxel_labels"][name] = score(s->voxels);
  }
  const bool by_icm = ground.solver == GroundSegmentationConfig::Solver::Icm;
  const ScanLabels& configured = by_icm ? icm : cut;
  j["confusion"] = kittiConfusion(points, labels, configured.points);
  j["confusion"]["method"] = by_icm ? "gmrf_icm" : "gmrf_mincut";
  j["histogram"] = score(configured.rough);
  j["fixed_band"] = score(groundByFixedBand(points, {Point3(0, 0, -sensor_height)}, ground.delta));
  j["ransac_plane"] = score(groundByRansacPlane(points, 0.2));
  j["morphological_filter"] = score(groundByMorphologicalFilter(points, MorphologicalFilterConfig{}));
  return j;
}

}  // namespace terrain::eval
