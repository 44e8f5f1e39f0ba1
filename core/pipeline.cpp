#include "core/pipeline.hpp"

#include "core/camera_model.hpp"

#include <chrono>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

#include <unistd.h>

namespace terrain {

namespace {

using Clock = std::chrono::steady_clock;

// [m] the least travel a short run's initial heading and pitch are taken from
constexpr double kMinTravel = 0.5;

// resident memory of this process [bytes], from /proc/self/statm; 0 where that is not available
std::size_t residentBytes() {
  std::ifstream statm("/proc/self/statm");
  std::size_t pages = 0, resident = 0;
  if (!(statm >> pages >> resident)) return 0;
  return resident * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

}  // namespace

Pipeline::Pipeline(const RigCalibration& calibration, const PipelineConfig& config)
    : calibration_(calibration),
      config_(config),
      poses_(calibration, config.pose),
      map_(config.voxel_map),
      incremental_(config.ground) {}

void Pipeline::warn(const std::string& message) {
  if (warnings_.size() < 1000) warnings_.push_back(message);
}

void Pipeline::process(const SensorFrame& frame) {
  const std::string id = "frame " + std::to_string(frame.index) + ": ";
  if (frame.sweep.points.empty()) warn(id + "empty lidar sweep");
  if (frame.gps.empty()) warn(id + "no GPS fix");
  if (frame.gyro.empty()) warn(id + "no gyro samples");
  if (!frame.image) warn(id + "no camera image");
  const auto t0 = Clock::now();
  const GpsUpdate gps = poses_.add(frame);
  if (gps.dropped > 0) {
    std::ostringstream m;
    m << id << gps.dropped << " GPS fix(es) dropped: farther from the previous fix than " << config_.pose.max_speed
      << " m/s allows";
    warn(m.str());
  }
  if (gps.discarded > 0) {
    std::ostringstream m;
    m << id << "GPS track started over: its first " << gps.discarded
      << " fix(es) disagreed with more fixes after them and were discarded";
    warn(m.str());
  }
  const double pose_ms = msSince(t0);
  held_.push_back({frame, pose_ms});
  if (!poses_.ready()) return;
  // a frame waits until the GPS fixes after it no longer change its poses
  while (!held_.empty() && held_.front().frame.sweep.end_time <= poses_.finalUntil()) {
    processReady(held_.front().frame);
    records_.back().pose_ms += held_.front().pose_ms;
    held_.pop_front();
  }
}

void Pipeline::finish() {
  if (!held_.empty()) {
    if (!poses_.ready() && poses_.settle(kMinTravel)) {
      std::ostringstream m;
      m << "the robot moved less than " << config_.pose.heading_baseline
        << " m: initial heading and pitch from a shorter stretch, less accurate";
      warn(m.str());
    }
    if (!poses_.ready()) {
      std::ostringstream m;
      m << "the robot never moved " << kMinTravel << " m: heading unknown, frames processed with heading 0 (east)";
      warn(m.str());
    }
    while (!held_.empty()) {
      processReady(held_.front().frame);
      records_.back().pose_ms += held_.front().pose_ms;
      held_.pop_front();
    }
  }
  // the final labels from one segmentation of the whole map
  if (!map_.voxels().empty()) segmentation_ = segmentGround(map_, config_.ground);
  dirty_ = false;
  // estimates made while a vertex was provisionally non-ground do not stand once it is ground
  for (auto& m : mesh_.vertices()) {
    if (map_.voxels()[m.top_voxel].label == VoxelLabel::Ground) m.estimates.clear(), m.parallax = false;
  }
  holdBackYoungVertices(mesh_, map_, config_.estimation);
  spreadEstimates(mesh_, map_, config_.estimation);
  completeFootprints();
  crowns_.apply(mesh_, map_, config_.crown);
  for (auto& r : records_) {
    const Pose pose = poses_.worldFromVehicle(r.time);
    r.position = pose.translation();
    r.attitude = Rotation(pose.linear());
  }
  if (!map_.voxels().empty()) {
    std::size_t ground = 0;
    for (auto g : segmentation_.refined) ground += g;
    if (ground == 0) warn("no voxel was labelled ground");
    if (ground == segmentation_.refined.size()) warn("every voxel was labelled ground: no objects");
  }
}

bool Pipeline::restore(std::vector<Voxel> voxels, std::vector<MeshVertex> vertices, SegmentationResult segmentation,
                       std::vector<FrameRecord> records, const std::vector<CrownRecord>& crowns) {
  const std::size_t n = voxels.size();
  if (segmentation.rough.size() != n || segmentation.refined.size() != n || segmentation.ground_height.size() != n)
    return false;
  for (const auto& v : vertices) {
    if (v.top_voxel >= n) return false;
  }
  if (!map_.restore(std::move(voxels))) return false;
  if (!mesh_.restore(std::move(vertices))) return false;
  segmentation_ = std::move(segmentation);
  records_ = std::move(records);
  crowns_.restoreRecords(crowns);
  held_.clear();
  dirty_ = false;
  completeFootprints();
  return true;
}

void Pipeline::completeFootprints() {
  footprints_ = terrain::completeFootprints(mesh_, map_, config_.footprint);
  roofWalls(mesh_, map_, footprints_, config_.footprint);
  roof_cells_ = terrain::roofCells(footprints_, mesh_, map_.voxelSize());
}

void Pipeline::processReady(const SensorFrame& frame) {
  const auto start = Clock::now();
  FrameRecord rec;
  rec.frame = frame.index;
  rec.time = frame.sweep.start_time;
  const std::string id = "frame " + std::to_string(frame.index) + ": ";

  // pose and de-skew
  auto t = Clock::now();
  int dropped = 0;
  const std::vector<Point3> world = deskewToWorld(frame.sweep, poses_, calibration_.vehicle_from_lidar, &dropped);
  if (dropped > 0) warn(id + std::to_string(dropped) + " lidar points with NaN or infinite values dropped");
  rec.points = world.size();
  // colour of each point from the image taken with the sweep
  std::vector<std::array<std::uint8_t, 4>> colours;
  const bool has_image = frame.image && !frame.image->rgb.empty() && frame.image->rgb.type() == CV_8UC3;
  Pose world_from_camera = Pose::Identity();
  if (has_image) {
    world_from_camera = poses_.worldFromVehicle(frame.image->time) * calibration_.vehicle_from_camera;
    const Pose camera_from_world = world_from_camera.inverse();
    const cv::Mat& rgb = frame.image->rgb;
    colours.resize(world.size(), {0, 0, 0, 0});
    for (std::size_t i = 0; i < world.size(); ++i) {
      const auto px = project(calibration_.camera, camera_from_world * world[i]);
      if (!px || px->y() >= rgb.rows || px->x() >= rgb.cols) continue;
      const auto& c = rgb.at<cv::Vec3b>(static_cast<int>(px->y()), static_cast<int>(px->x()));
      colours[i] = {c[0], c[1], c[2], 1};
    }
  } else if (frame.image) {
    warn(id + "camera image is empty or not 8-bit RGB: ignored");
  }
  rec.pose_ms = msSince(t);

  // voxel map
  t = Clock::now();
  rec.new_voxels = map_.insert(world, static_cast<std::uint32_t>(frame.index), has_image ? &colours : nullptr);
  rec.voxels = map_.size();
  const std::vector<std::uint32_t> new_ids = map_.takeNewVoxels();
  // the incremental segmentation re-segments the tiles that gained voxels (ground.defer_share);
  // existing voxels only refine their mean height, which the whole-map segmentation at finish()
  // takes in
  dirty_ = dirty_ || !new_ids.empty();
  rec.voxel_ms = msSince(t);

  // terrain mesh
  t = Clock::now();
  mesh_.update(map_, new_ids);
  rec.mesh_ms = msSince(t);

  // ground segmentation
  t = Clock::now();
  ++processed_;
  if (dirty_ && processed_ % std::max(1, config_.segment_every) == 0) {
    // only the tiles this frame's points fell in, and their surroundings
    incremental_.update(map_);
    dirty_ = false;
  }
  rec.segmentation_ms = msSince(t);

  // 2D boundaries and 3D boundary estimation
  if (has_image) {
    t = Clock::now();
    last_boundaries_ = detectBoundaries(frame.image->rgb, config_.boundary);
    last_boundary_frame_ = frame.index;
    rec.boundary_ms = msSince(t);
    t = Clock::now();
    // the objects in the camera's view, found once for both the clear-line test and the crowns
    std::optional<SkylineOwners> owners;
    if (config_.estimation.clear_line || config_.crown.enabled) {
      owners.emplace(mesh_, map_,
                     viewRegion(calibration_.camera, world_from_camera,
                                config_.crown.enabled ? CrownSampler::ownersReach(config_.crown, config_.estimation)
                                                      : config_.estimation.max_distance));
    }
    const SkylineOwners* shared = owners ? &*owners : nullptr;
    const BoundaryEstimationStats stats =
        estimateBoundaries(mesh_, map_, last_boundaries_.cleaned, calibration_.camera, world_from_camera,
                           config_.estimation, frame.image->rgb, shared);
    rec.estimated_vertices = stats.estimated;
    if (stats.projected == 0 && !map_.voxels().empty()) warn(id + "the camera sees no non-ground vertex");
    if (owners) owners->refreshTops(mesh_);
    crowns_.measure(mesh_, map_, frame.image->rgb, calibration_.camera, world_from_camera, config_.crown,
                    config_.estimation, shared);
    rec.estimation_ms = msSince(t);
  }
  rec.total_ms = msSince(start);
  rec.resident_bytes = residentBytes();
  records_.push_back(rec);
}

}  // namespace terrain
