#include "core/pipeline.hpp"

#include "core/camera_model.hpp"

#include <algorithm>
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
      ceiling_(config.voxel_map.voxel_size),
      incremental_(config.ground) {}

void Pipeline::warn(const std::string& message) {
  if (warnings_.size() < 1000) warnings_.push_back(message);
}

void Pipeline::process(const SensorFrame& frame) {
  const std::string id = "frame " + std::to_string(frame.index) + ": ";
  if (frame.sweep.points.empty()) warn(id + "empty lidar sweep");
  if (frame.gps.empty()) warn(id + "no GPS fix");
  if (frame.gyro.empty()) warn(id + "no gyro samples");
  // every camera of the rig is expected to deliver an image with each sweep
  for (std::size_t c = 0; c < calibration_.cameras.size(); ++c) {
    const bool delivered = std::any_of(frame.images.begin(), frame.images.end(),
                                       [c](const CameraImage& i) { return i.camera == static_cast<int>(c); });
    if (!delivered) warn(id + "no image from camera " + calibration_.cameras[c].name);
  }
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
  const CrownHullConfig guard = skyGuardHull(config_.crown, config_.estimation);
  // the sky guard bounds what boundary estimation raised on trunks: a trunk's vertex stands no
  // higher than where the sky showed through its column without a break from above (a top edge
  // taken from a nearer crown, or one behind, that the clear line did not know)
  if (config_.crown.enabled && config_.crown.guard_estimates)
    lowerUnderSky(mesh_, map_, sky_guard_, guard, config_.crown);
  crowns_.apply(mesh_, map_, config_.crown,
                [&](double x, double y, double lo, double hi) { return sky_guard_.skyThrough(x, y, lo, hi, guard); });
  hull_raised_ = hull_.apply(mesh_, map_, config_.hull, config_.crown);
  if (config_.free_space.enabled) sky_lowered_ = ceiling_.apply(mesh_, map_);
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
  // the frame's usable images and where each camera was when it took its image
  struct View {
    const CameraImage* image;
    const CameraCalibration* camera;
    Pose world_from_camera;
  };
  std::vector<View> views;
  for (const CameraImage& image : frame.images) {
    if (image.camera < 0 || image.camera >= static_cast<int>(calibration_.cameras.size())) {
      warn(id + "image of camera " + std::to_string(image.camera) + ", which the calibration does not list: ignored");
      continue;
    }
    const CameraCalibration& camera = calibration_.cameras[image.camera];
    if (image.rgb.empty() || image.rgb.type() != CV_8UC3) {
      warn(id + "camera " + camera.name + ": image is empty or not 8-bit RGB: ignored");
      continue;
    }
    views.push_back({&image, &camera, poses_.worldFromVehicle(image.time) * camera.vehicle_from_camera});
  }
  // colour of each point from the camera that sees it most head-on (the cameras sit close
  // together on the mast, so the nearest camera is much the same for every one of them)
  std::vector<std::array<std::uint8_t, 4>> colours;
  if (!views.empty()) {
    std::vector<Pose> camera_from_world;
    for (const View& v : views) camera_from_world.push_back(v.world_from_camera.inverse());
    colours.resize(world.size(), {0, 0, 0, 0});
    for (std::size_t i = 0; i < world.size(); ++i) {
      double best = -1;  // cosine of the angle between the point's ray and the optical axis
      for (std::size_t c = 0; c < views.size(); ++c) {
        const Point3 p = camera_from_world[c] * world[i];
        const cv::Mat& rgb = views[c].image->rgb;
        const auto px = project(views[c].camera->intrinsics, p);
        if (!px || px->y() >= rgb.rows || px->x() >= rgb.cols) continue;
        const double head_on = p.z() / p.norm();
        if (!(head_on > best)) continue;
        best = head_on;
        const auto& colour = rgb.at<cv::Vec3b>(static_cast<int>(px->y()), static_cast<int>(px->x()));
        colours[i] = {colour[0], colour[1], colour[2], 1};
      }
    }
  }
  rec.pose_ms = msSince(t);

  // voxel map
  t = Clock::now();
  rec.new_voxels = map_.insert(world, static_cast<std::uint32_t>(frame.index), views.empty() ? nullptr : &colours);
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

  // 2D boundaries and 3D boundary estimation, in every camera's image: the estimates of a vertex
  // from all cameras and frames are fused alike
  if (!views.empty()) last_boundaries_.clear(), last_boundary_frame_ = frame.index;
  int projected = 0;
  for (const View& view : views) {
    t = Clock::now();
    const cv::Mat& rgb = view.image->rgb;
    last_boundaries_.push_back({view.image->camera, detectBoundaries(rgb, config_.boundary)});
    const BoundaryImages& boundaries = last_boundaries_.back().images;
    rec.boundary_ms += msSince(t);
    t = Clock::now();
    // the objects in the camera's view, found once for both the clear-line test and the crowns
    std::optional<SkylineOwners> owners;
    const CameraIntrinsics& k = view.camera->intrinsics;
    if (config_.estimation.clear_line || config_.crown.enabled || config_.hull.enabled) {
      owners.emplace(mesh_, map_,
                     viewRegion(k, view.world_from_camera,
                                config_.crown.enabled || config_.hull.enabled
                                    ? std::max(CrownSampler::ownersReach(config_.crown, config_.estimation),
                                               config_.hull.max_distance + config_.hull.max_radius)
                                    : config_.estimation.max_distance));
    }
    const SkylineOwners* shared = owners ? &*owners : nullptr;
    const BoundaryEstimationStats stats =
        estimateBoundaries(mesh_, map_, boundaries.cleaned, k, view.world_from_camera, config_.estimation, rgb, shared);
    rec.estimated_vertices += stats.estimated;
    projected += stats.projected;
    if (owners) owners->refreshTops(mesh_);
    crowns_.measure(mesh_, map_, rgb, k, view.world_from_camera, config_.crown, config_.estimation, shared);
    if (owners && config_.crown.enabled && (config_.crown.sky_guard || config_.crown.guard_estimates))
      sky_guard_.carve(mesh_, map_, rgb, k, view.world_from_camera, *owners,
                       skyGuardHull(config_.crown, config_.estimation), config_.crown, config_.estimation);
    if (owners)
      hull_.carve(mesh_, map_, rgb, k, view.world_from_camera, *owners, config_.hull, config_.crown,
                  config_.estimation);
    ceiling_.carve(rgb, k, view.world_from_camera, config_.free_space, config_.estimation);
    rec.estimation_ms += msSince(t);
  }
  if (!views.empty() && projected == 0 && !map_.voxels().empty()) warn(id + "no camera sees a non-ground vertex");
  rec.total_ms = msSince(start);
  rec.resident_bytes = residentBytes();
  records_.push_back(rec);
}

}  // namespace terrain
