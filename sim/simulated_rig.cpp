#include "sim/simulated_rig.hpp"

#include "rig/file_io.hpp"

#include <cmath>

namespace terrain::sim {

namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// the index of the first sample of a fixed-rate stream at or after time t
long long firstIndexAtOrAfter(double t, double period) { return static_cast<long long>(std::ceil(t / period - 1e-9)); }

}  // namespace

RigCalibration SimulatedRig::calibrationFor(const SimConfig& c, const GeodeticOrigin& origin) {
  RigCalibration cal;
  cal.vehicle_from_lidar = Pose::Identity();
  cal.vehicle_from_lidar.translation() = Vector3(0, 0, c.robot.mast_height);
  for (const CameraMount& m : rigCameras(c.camera)) {
    CameraCalibration camera;
    camera.name = m.name;
    camera.intrinsics = CameraIntrinsics::fromFovy(m.width, m.height, m.fovy_deg * kDegToRad);
    // a camera looking forward, tilted up by pitch (z forward, x right, y down), turned by yaw
    // about the vehicle's z axis and by roll about its optical axis
    const double p = m.pitch_deg * kDegToRad;
    Eigen::Matrix3d forward;
    forward.col(0) = Vector3(0, -1, 0);
    forward.col(1) = Vector3(std::sin(p), 0, -std::cos(p));
    forward.col(2) = Vector3(std::cos(p), 0, std::sin(p));
    const Eigen::Matrix3d yaw = Eigen::AngleAxisd(m.yaw_deg * kDegToRad, Vector3::UnitZ()).toRotationMatrix();
    const Eigen::Matrix3d roll = Eigen::AngleAxisd(m.roll_deg * kDegToRad, Vector3::UnitZ()).toRotationMatrix();
    camera.vehicle_from_camera = Pose::Identity();
    camera.vehicle_from_camera.linear() =
        m.yaw_deg == 0 && m.roll_deg == 0 ? forward : Eigen::Matrix3d(yaw * forward * roll);
    camera.vehicle_from_camera.translation() = m.position;
    cal.cameras.push_back(camera);
  }
  cal.vehicle_from_gps = Pose::Identity();
  cal.vehicle_from_gps.translation() = c.gps.antenna;
  cal.origin = origin;
  cal.gyro_period = 1.0 / c.gyro.rate_hz;
  return cal;
}

SimulatedRig::SimulatedRig(std::shared_ptr<const World> world, const SimConfig& config, int frames)
    : world_(std::move(world)),
      config_(config),
      frames_(frames),
      gps_(world_->truth().origin, config.gps, config.seed),
      gyro_(config.gyro, config.seed) {
  validate(config_);
  if (frames_ < 1) throw io::InputError("frames = " + std::to_string(frames_) + " is out of range (allowed: >= 1)");
  calibration_ = calibrationFor(config_, world_->truth().origin);
  const std::filesystem::path cal_file = config_.lidar.calibration.empty()
                                             ? dataPath("calibration/hdl64e_s2.1-sztaki.yaml")
                                             : std::filesystem::path(config_.lidar.calibration);
  rig::LaserCalibration lasers = rig::loadLaserCalibration(cal_file);
  caster_ = std::make_unique<RayCaster>(world_->model(), world_->data(), world_->robotBody());
  trajectory_ = std::make_unique<Trajectory>(*world_, world_->truth().path, config_.robot);
  lidar_ = std::make_unique<LidarSimulator>(*world_, *caster_, std::move(lasers), config_.lidar,
                                            calibration_.vehicle_from_lidar, config_.seed, config_.threads);
  for (const CameraMount& m : rigCameras(config_.camera))
    cameras_.push_back(std::make_unique<CameraRenderer>(*world_, m));
}

SimulatedRig::~SimulatedRig() = default;

int SimulatedRig::firingsPerTurn() const { return lidar_->firingsPerTurn(); }

std::optional<rig::RigFrame> SimulatedRig::next() {
  if (next_ >= frames_) return std::nullopt;
  const int k = next_++;
  const double period = 1.0 / config_.lidar.rotation_hz;
  const double start = k * period, end = start + period;
  rig::RigFrame frame;
  SensorFrame& s = frame.sensors;
  rig::FrameTruth truth;
  s.index = k;

  SimulatedSweep sweep = lidar_->simulate(k, start, *trajectory_);
  rays_ += sweep.rays;
  s.sweep = std::move(sweep.sweep);
  truth.points = std::move(sweep.truth);

  // every camera's exposure at the start of the sweep
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const Pose world_from_camera = trajectory_->worldFromVehicle(start) * calibration_.cameras[c].vehicle_from_camera;
    CameraRender r = cameras_[c]->render(world_from_camera);
    s.images.push_back(CameraImage{static_cast<int>(c), start, r.rgb});
    truth.cameras.push_back({static_cast<int>(c), r.depth, r.segmentation});
  }
  // GPS fixes and gyro samples whose time lies in [start, end)
  const double gps_period = 1.0 / config_.gps.rate_hz;
  for (long long i = firstIndexAtOrAfter(start, gps_period); i * gps_period < end - 1e-9; ++i) {
    const double t = i * gps_period;
    s.gps.push_back(gps_.fix(static_cast<int>(i), t, trajectory_->worldFromVehicle(t)));
  }
  const double dt = gyro_.period();
  for (long long i = firstIndexAtOrAfter(start, dt); i * dt < end - 1e-9; ++i) {
    const double t = i * dt;
    const Pose now = trajectory_->worldFromVehicle(t);
    truth.poses.push_back({t, now});
    if (i == 0) continue;  // the first sample covers (-dt, 0]: the robot stands still
    const Pose before = trajectory_->worldFromVehicle(t - dt);
    s.gyro.push_back(gyro_.sample(static_cast<int>(i), t, before.linear(), now.linear()));
  }
  frame.truth = std::move(truth);
  return frame;
}

}  // namespace terrain::sim
