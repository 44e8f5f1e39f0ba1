#include "core/pose_estimation.hpp"

#include <GeographicLib/LocalCartesian.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

namespace terrain {

PoseEstimator::PoseEstimator(const RigCalibration& calibration, const PoseConfig& config)
    : calibration_(calibration), config_(config) {}

Vector3 PoseEstimator::gpsToWorld(const GpsFix& f) const {
  const GeographicLib::LocalCartesian enu(calibration_.origin.latitude_deg, calibration_.origin.longitude_deg,
                                          calibration_.origin.altitude_m);
  double x, y, z;
  enu.Forward(f.latitude_deg, f.longitude_deg, f.altitude_m, x, y, z);
  return {x, y, z};
}

// roll and pitch from a least-squares plane through the lowest lidar point of each cell near the
// robot, with one round of outlier rejection
void PoseEstimator::levelFromSweep(const LidarSweep& sweep) {
  std::map<std::pair<int, int>, Point3> lowest;
  for (const auto& p : sweep.points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    const double r = std::hypot(p.x, p.y);
    if (r < config_.level_min_range || r > config_.level_max_range) continue;
    const Point3 q = calibration_.vehicle_from_lidar * Point3(p.x, p.y, p.z);
    const std::pair<int, int> key{static_cast<int>(std::floor(q.x() / config_.level_cell)),
                                  static_cast<int>(std::floor(q.y() / config_.level_cell))};
    auto it = lowest.find(key);
    if (it == lowest.end() || q.z() < it->second.z()) lowest[key] = q;
  }
  std::vector<Point3> pts;
  for (const auto& [key, p] : lowest) pts.push_back(p);
  Eigen::Vector3d plane(0, 0, 0);  // z = a x + b y + c
  for (int round = 0; round < 2 && pts.size() >= 3; ++round) {
    Eigen::MatrixXd a(pts.size(), 3);
    Eigen::VectorXd b(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) {
      a.row(i) << pts[i].x(), pts[i].y(), 1.0;
      b[i] = pts[i].z();
    }
    plane = a.colPivHouseholderQr().solve(b);
    std::vector<Point3> kept;
    for (const auto& p : pts) {
      if (std::abs(plane[0] * p.x() + plane[1] * p.y() + plane[2] - p.z()) < 0.15) kept.push_back(p);
    }
    pts.swap(kept);
  }
  // the ground normal in the vehicle frame is the world up axis seen from the vehicle
  ground_up_ = Vector3(-plane[0], -plane[1], 1.0).normalized();
  levelled_ = true;
}

GpsUpdate PoseEstimator::add(const SensorFrame& frame) {
  if (!levelled_) levelFromSweep(frame.sweep);
  // integrate the gyro: each sample is the mean rate over the preceding period
  if (rotations_.empty()) {
    const double t0 = frame.gyro.empty() ? frame.sweep.start_time : frame.gyro.front().time - calibration_.gyro_period;
    rotations_.push_back({t0, Rotation::Identity()});
  }
  for (const auto& g : frame.gyro) {
    if (!g.rate.allFinite() || g.time <= rotations_.back().time) continue;
    const double dt = g.time - rotations_.back().time;
    const double angle = g.rate.norm() * dt;
    const Rotation step = angle > 0 ? Rotation(Eigen::AngleAxisd(angle, g.rate.normalized())) : Rotation::Identity();
    rotations_.push_back({g.time, (rotations_.back().world_from_vehicle * step).normalized()});
  }
  // GPS: antenna positions; new fixes change the smoothed values within one window before them
  const std::size_t first_new = raw_.size();
  GpsUpdate update;
  for (const auto& f : frame.gps) {
    if (!std::isfinite(f.latitude_deg) || !std::isfinite(f.longitude_deg) || !std::isfinite(f.altitude_m)) continue;
    if (!raw_.empty() && f.time <= raw_.back().first) continue;
    const Fix fix{f.time, gpsToWorld(f), std::isfinite(f.sigma_m) && f.sigma_m > 0 ? f.sigma_m : 0.0};
    // a jump no vehicle makes from the last fix kept: a glitch, dropped (else one bad fix would
    // stretch the map over kilometres); the dropped fixes that agree with each other are remembered
    if (!raw_.empty() && !reachable({raw_.back().first, raw_.back().second, last_sigma_}, fix)) {
      ++update.dropped;
      if (!jumped_.empty() && !reachable(jumped_.back(), fix)) jumped_.clear();
      jumped_.push_back(fix);
      continue;
    }
    jumped_.clear();
    raw_.emplace_back(fix.time, fix.at);
    last_sigma_ = fix.sigma;
  }
  if (!heading_known_ && jumped_.size() >= 3 && jumped_.size() > raw_.size()) {
    // before the heading is known, more dropped fixes agreeing with each other than fixes kept: the
    // kept ones were the glitch (a receiver's wild first fixes). The track starts over from the others.
    update.discarded = raw_.size();
    raw_.clear();
    for (const Fix& j : jumped_) raw_.emplace_back(j.time, j.at);
    last_sigma_ = jumped_.back().sigma;
    jumped_.clear();
    smoothFrom(0);
  } else if (raw_.size() > first_new) {
    smoothFrom(first_new);
  }
  if (!heading_known_ && antenna_.size() >= 2 &&
      (antenna_.back().second - antenna_.front().second).head<2>().norm() >= config_.heading_baseline) {
    heading_known_ = alignment(initial_, config_.heading_baseline);
  }
  return update;
}

bool PoseEstimator::reachable(const Fix& from, const Fix& to) const {
  const double allowed = config_.max_speed * (to.time - from.time) + 3 * (from.sigma + to.sigma) + 1;
  return (to.at - from.at).norm() <= allowed;
}

bool PoseEstimator::settle(double min_travel) {
  if (!heading_known_) heading_known_ = alignment(initial_, min_travel);
  return heading_known_;
}

bool PoseEstimator::alignment(Rotation& out, double min_travel) const {
  const std::size_t n = raw_.size();
  if (n < 3) return false;
  // per fix: the distance travelled since the first (tau) and where the gyro alone puts the antenna
  // relative to the first fix (m: the integrated forward axis plus the lever arm's own motion)
  const Vector3 lever = calibration_.vehicle_from_gps.translation();
  const Eigen::Matrix3d g_first = gyroAt(raw_.front().first).toRotationMatrix();
  std::vector<double> tau(n, 0.0);
  std::vector<Vector3> m(n, Vector3::Zero());
  Vector3 travelled = Vector3::Zero();
  for (std::size_t i = 1; i < n; ++i) {
    const double step = (antenna_[i].second - antenna_[i - 1].second).norm();
    const double mid = 0.5 * (raw_[i - 1].first + raw_[i].first);
    travelled += step * (gyroAt(mid) * Vector3::UnitX());
    tau[i] = tau[i - 1] + step;
    m[i] = travelled + (gyroAt(raw_[i].first).toRotationMatrix() - g_first) * lever;
  }
  if (tau.back() < min_travel) return false;
  // least-squares directions: the slopes of the GPS positions and of m against tau
  double tau_mean = 0;
  Vector3 a_mean = Vector3::Zero(), m_mean = Vector3::Zero();
  for (std::size_t k = 0; k < n; ++k) tau_mean += tau[k], a_mean += raw_[k].second, m_mean += m[k];
  tau_mean /= n, a_mean /= n, m_mean /= n;
  Vector3 course = Vector3::Zero(), forward = Vector3::Zero();
  double stt = 0;
  for (std::size_t k = 0; k < n; ++k) {
    course += (raw_[k].second - a_mean) * (tau[k] - tau_mean);
    forward += (m[k] - m_mean) * (tau[k] - tau_mean);
    stt += (tau[k] - tau_mean) * (tau[k] - tau_mean);
  }
  if (forward.norm() < 1e-9 || course.head<2>().norm() < 1e-9) return false;
  // Pitch: the GPS course's, weighed against the pitch that makes the first sweep's ground plane
  // level, by their variances: the course's from the scatter of the heights about their line (a
  // short baseline leaves it to the ground plane), the ground plane's from level_pitch_sigma.
  const double slope = course.z() / stt;
  double szz = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double r = raw_[k].second.z() - a_mean.z() - slope * (tau[k] - tau_mean);
    szz += r * r;
  }
  const double slope_var = szz / std::max(1.0, static_cast<double>(n) - 2) / stt;
  const Vector3 ground_up = rotations_.front().world_from_vehicle * ground_up_;  // first sweep, gyro frame
  const Vector3 f0 = Vector3(course.x(), course.y(), 0.0).normalized();
  const Vector3 up0 = Rotation::FromTwoVectors(forward.normalized(), f0) * ground_up;
  const double pitch_level = std::atan2(up0.dot(f0), up0.z());
  const double pitch_gps = std::atan2(course.z(), course.head<2>().norm());
  const double prior_var = config_.level_pitch_sigma * config_.level_pitch_sigma;
  const double w = prior_var / (prior_var + slope_var);
  const double pitch = w * pitch_gps + (1 - w) * pitch_level;
  const Vector3 f = f0 * std::cos(pitch) + Vector3::UnitZ() * std::sin(pitch);
  const Rotation align = Rotation::FromTwoVectors(forward.normalized(), f);
  // roll about the course: bring the first sweep's ground normal as close to vertical as it goes
  const Vector3 up = align * ground_up;
  const Vector3 u = (up - up.dot(f) * f), z = (Vector3::UnitZ() - f.z() * f);
  double roll = 0;
  if (u.norm() > 1e-9 && z.norm() > 1e-9) roll = std::atan2(f.dot(u.cross(z)), u.dot(z));
  out = (Rotation(Eigen::AngleAxisd(roll, f)) * align).normalized();
  return true;
}

void PoseEstimator::smoothFrom(std::size_t first_new) {
  antenna_.resize(raw_.size());
  const double w = config_.smoothing_window;
  // the fixes whose window reaches a new fix
  std::size_t start = first_new;
  while (start > 0 && raw_[start - 1].first >= raw_[first_new].first - w) --start;
  for (std::size_t i = start; i < raw_.size(); ++i) {
    const double t = raw_[i].first;
    std::size_t lo = i, hi = i;
    while (lo > 0 && raw_[lo - 1].first >= t - w) --lo;
    while (hi + 1 < raw_.size() && raw_[hi + 1].first <= t + w) ++hi;
    antenna_[i] = raw_[i];
    if (w <= 0 || hi - lo + 1 < 4) continue;
    // least squares p(s) = c0 + c1 s + c2 s^2, s = t_k - t; the smoothed value is c0
    Eigen::MatrixXd a(hi - lo + 1, 3);
    Eigen::MatrixXd b(hi - lo + 1, 3);
    for (std::size_t k = lo; k <= hi; ++k) {
      const double ds = raw_[k].first - t;
      a.row(k - lo) << 1.0, ds, ds * ds;
      b.row(k - lo) = raw_[k].second.transpose();
    }
    const Eigen::MatrixXd c = a.colPivHouseholderQr().solve(b);
    antenna_[i].second = c.row(0).transpose();
  }
}

double PoseEstimator::finalUntil() const {
  if (raw_.empty()) return -std::numeric_limits<double>::infinity();
  return raw_.back().first - config_.smoothing_window;
}

Rotation PoseEstimator::gyroAt(double t) const {
  if (rotations_.empty()) return Rotation::Identity();
  auto it = std::lower_bound(rotations_.begin(), rotations_.end(), t,
                             [](const TimedRotation& r, double v) { return r.time < v; });
  if (it == rotations_.begin()) return it->world_from_vehicle;
  if (it == rotations_.end()) return rotations_.back().world_from_vehicle;
  const TimedRotation& b = *it;
  const TimedRotation& a = *(it - 1);
  const double s = (t - a.time) / (b.time - a.time);
  return a.world_from_vehicle.slerp(s, b.world_from_vehicle);
}

Rotation PoseEstimator::rotationAt(double t) const { return initial_ * gyroAt(t); }

Vector3 PoseEstimator::antennaAt(double t) const {
  if (antenna_.empty()) return Vector3::Zero();
  auto it = std::lower_bound(antenna_.begin(), antenna_.end(), t,
                             [](const std::pair<double, Vector3>& a, double v) { return a.first < v; });
  if (it == antenna_.begin()) return it->second;
  if (it == antenna_.end()) {
    // past the last fix: extrapolate with the last velocity
    if (antenna_.size() < 2) return antenna_.back().second;
    const auto& a = antenna_[antenna_.size() - 2];
    const auto& b = antenna_.back();
    return b.second + (b.second - a.second) * (t - b.first) / (b.first - a.first);
  }
  const auto& b = *it;
  const auto& a = *(it - 1);
  return a.second + (b.second - a.second) * (t - a.first) / (b.first - a.first);
}

Pose PoseEstimator::worldFromVehicle(double t) const {
  Pose p = Pose::Identity();
  p.linear() = rotationAt(t).toRotationMatrix();
  p.translation() = antennaAt(t) - p.linear() * calibration_.vehicle_from_gps.translation();
  return p;
}

std::vector<Point3> deskewToWorld(const LidarSweep& sweep, const PoseEstimator& poses, const Pose& vehicle_from_lidar,
                                  int* dropped) {
  std::vector<Point3> out;
  out.reserve(sweep.points.size());
  int bad = 0;
  // poses change slowly: evaluate once per distinct firing time
  double last_time = std::numeric_limits<double>::quiet_NaN();
  Pose world_from_lidar = Pose::Identity();
  for (const auto& p : sweep.points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.time)) {
      ++bad;
      continue;
    }
    if (p.time != last_time) {
      world_from_lidar = poses.worldFromVehicle(p.time) * vehicle_from_lidar;
      last_time = p.time;
    }
    out.push_back(world_from_lidar * Point3(p.x, p.y, p.z));
  }
  if (dropped) *dropped = bad;
  return out;
}

}  // namespace terrain
