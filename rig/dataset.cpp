#include "rig/dataset.hpp"

#include "rig/file_io.hpp"
#include "rig/pcd.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>
#include <sstream>

namespace terrain::rig {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string frameName(int index, const char* suffix) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%06d%s", index, suffix);
  return buf;
}

// round-trip formatting of doubles in CSV
std::string g17(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

json poseToJson(const Pose& p) {
  json rows = json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({p.matrix()(r, 0), p.matrix()(r, 1), p.matrix()(r, 2), p.matrix()(r, 3)});
  return rows;
}

Pose poseFromJson(const json& j, const std::string& origin, const std::string& field) {
  if (!j.is_array() || j.size() != 4) throw io::InputError(origin + ": '" + field + "' must be a 4x4 matrix");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    if (!j[r].is_array() || j[r].size() != 4) throw io::InputError(origin + ": '" + field + "' must be a 4x4 matrix");
    for (int c = 0; c < 4; ++c) m(r, c) = j[r][c].get<double>();
  }
  const Eigen::Matrix3d rot = m.topLeftCorner<3, 3>();
  if (!((rot.transpose() * rot - Eigen::Matrix3d::Identity()).norm() < 1e-6)) {
    throw io::InputError(origin + ": '" + field + "' rotation part is not orthonormal");
  }
  Pose p = Pose::Identity();
  p.matrix() = m;
  return p;
}

void writeImage(const fs::path& path, const cv::Mat& image) {
  std::vector<uchar> buf;
  const std::string ext = path.extension().string();
  if (!cv::imencode(ext, image, buf)) throw io::InputError(path.string() + ": image encoding failed");
  io::writeFileAtomic(path, std::string(buf.begin(), buf.end()), true);
}

cv::Mat readImage(const fs::path& path, int flags, int expected_type) {
  const std::string bytes = io::readFile(path);
  cv::Mat img =
      cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())), flags);
  if (img.empty()) throw io::InputError(path.string() + ": not a readable image");
  if (img.type() != expected_type) throw io::InputError(path.string() + ": unexpected pixel type");
  return img;
}

}  // namespace

double parseCsvNumber(const std::string& cell, const std::string& where) {
  try {
    std::size_t used = 0;
    const double v = std::stod(cell, &used);
    if (used != cell.size()) throw std::invalid_argument(cell);
    return v;
  } catch (const std::exception&) {
    throw io::InputError(where + "'" + cell + "' is not a number");
  }
}

namespace {

// splits CSV text into rows of numbers after a header line; names file and line on error
std::vector<std::vector<double>> readCsv(const fs::path& path, std::size_t columns, std::vector<int>* lines = nullptr) {
  std::istringstream in(io::readFile(path));
  std::string line;
  std::getline(in, line);  // header
  std::vector<std::vector<double>> rows;
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty()) continue;
    std::vector<double> row;
    std::istringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ','))
      row.push_back(parseCsvNumber(cell, path.string() + ":" + std::to_string(line_no) + ": "));
    if (row.size() != columns) {
      throw io::InputError(path.string() + ":" + std::to_string(line_no) + ": expected " + std::to_string(columns) +
                           " columns, found " + std::to_string(row.size()));
    }
    rows.push_back(std::move(row));
    if (lines) lines->push_back(line_no);
  }
  return rows;
}

// the rows of a sensor or truth stream: every value finite, times increasing, and what `check`
// says about each row (an empty string: fine), each failure named with the file and line
std::vector<std::vector<double>> readStream(const fs::path& path, std::size_t columns,
                                            const std::function<std::string(const std::vector<double>&)>& check) {
  std::vector<int> lines;
  auto rows = readCsv(path, columns, &lines);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto where = [&] { return path.string() + ":" + std::to_string(lines[i]) + ": "; };
    for (double v : rows[i]) {
      if (!std::isfinite(v)) throw io::InputError(where() + "a value is not finite (" + std::to_string(v) + ")");
    }
    if (i > 0 && rows[i][0] <= rows[i - 1][0])
      throw io::InputError(where() + "time does not increase from the row before");
    const std::string problem = check(rows[i]);
    if (!problem.empty()) throw io::InputError(where() + problem);
  }
  return rows;
}

// entries of a time-sorted stream whose time lies in [start, end)
template <typename T>
std::vector<T> window(const std::vector<T>& all, double start, double end) {
  std::vector<T> out;
  for (const T& x : all) {
    if (x.time >= start && x.time < end) out.push_back(x);
  }
  return out;
}

}  // namespace

std::vector<std::vector<double>> readSensorStream(const fs::path& path, std::size_t columns,
                                                  const std::function<std::string(const std::vector<double>&)>& check) {
  return readStream(
      path, columns, check ? check : [](const std::vector<double>&) { return std::string(); });
}

cv::Mat readRgbImage(const fs::path& path) {
  cv::Mat rgb;
  cv::cvtColor(readImage(path, cv::IMREAD_COLOR, CV_8UC3), rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

std::string calibrationToJson(const RigCalibration& c) {
  json j;
  json cameras = json::array();
  for (const CameraCalibration& cam : c.cameras) {
    const CameraIntrinsics& k = cam.intrinsics;
    cameras.push_back({{"name", cam.name},
                       {"width_px", k.width},
                       {"height_px", k.height},
                       {"fx_px", k.fx},
                       {"fy_px", k.fy},
                       {"cx_px", k.cx},
                       {"cy_px", k.cy},
                       {"model", "pinhole, no distortion; camera frame x right, y down, z forward"},
                       {"vehicle_from_camera", poseToJson(cam.vehicle_from_camera)}});
  }
  j["cameras"] = cameras;
  j["vehicle_from_lidar"] = poseToJson(c.vehicle_from_lidar);
  j["vehicle_from_gps"] = poseToJson(c.vehicle_from_gps);
  j["geodetic_origin"] = {{"latitude_deg", c.origin.latitude_deg},
                          {"longitude_deg", c.origin.longitude_deg},
                          {"altitude_m", c.origin.altitude_m}};
  j["gyro_period_s"] = c.gyro_period;
  return j.dump(1) + "\n";
}

namespace {

CameraIntrinsics intrinsicsFromJson(const json& cam) {
  CameraIntrinsics k;
  k.width = cam.at("width_px").get<int>();
  k.height = cam.at("height_px").get<int>();
  k.fx = cam.at("fx_px").get<double>();
  k.fy = cam.at("fy_px").get<double>();
  k.cx = cam.at("cx_px").get<double>();
  k.cy = cam.at("cy_px").get<double>();
  return k;
}

}  // namespace

void validateCameras(const std::vector<CameraCalibration>& cameras, const std::string& origin) {
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const CameraCalibration& c = cameras[i];
    const std::string where = origin + ": camera " + std::to_string(i) + " ('" + c.name + "')";
    if (c.name.empty()) throw io::InputError(origin + ": camera " + std::to_string(i) + " has no name");
    if (c.name.find_first_of("/\\.") != std::string::npos || c.name.find_first_of(" \t\n") != std::string::npos)
      throw io::InputError(where + ": a camera name may not hold '/', '\\', '.' or white space (it names a folder)");
    for (std::size_t j = 0; j < i; ++j) {
      if (cameras[j].name == c.name)
        throw io::InputError(where + ": duplicate camera name (also camera " + std::to_string(j) + ")");
    }
    const CameraIntrinsics& k = c.intrinsics;
    if (k.width <= 0 || k.height <= 0 || !(k.fx > 0) || !(k.fy > 0) || !std::isfinite(k.fx) || !std::isfinite(k.fy) ||
        !std::isfinite(k.cx) || !std::isfinite(k.cy))
      throw io::InputError(where + ": size and focal lengths must be positive and finite");
    if (!c.vehicle_from_camera.matrix().allFinite())
      throw io::InputError(where + ": vehicle_from_camera must be finite");
  }
}

RigCalibration calibrationFromJson(const std::string& text, const std::string& origin) {
  RigCalibration c;
  try {
    const json j = json::parse(text);
    if (j.contains("cameras")) {
      if (!j.at("cameras").is_array()) throw io::InputError(origin + ": 'cameras' must be a list");
      for (const json& cam : j.at("cameras")) {
        CameraCalibration camera;
        camera.name = cam.at("name").get<std::string>();
        camera.intrinsics = intrinsicsFromJson(cam);
        camera.vehicle_from_camera =
            poseFromJson(cam.at("vehicle_from_camera"), origin, "vehicle_from_camera of camera '" + camera.name + "'");
        c.cameras.push_back(camera);
      }
    } else {
      // format 1: one camera, "camera" and "vehicle_from_camera" at the top
      CameraCalibration camera;
      camera.name = kLegacyCameraName;
      camera.intrinsics = intrinsicsFromJson(j.at("camera"));
      camera.vehicle_from_camera = poseFromJson(j.at("vehicle_from_camera"), origin, "vehicle_from_camera");
      c.cameras.push_back(camera);
    }
    c.vehicle_from_lidar = poseFromJson(j.at("vehicle_from_lidar"), origin, "vehicle_from_lidar");
    c.vehicle_from_gps = poseFromJson(j.at("vehicle_from_gps"), origin, "vehicle_from_gps");
    const json& o = j.at("geodetic_origin");
    c.origin = {o.at("latitude_deg").get<double>(), o.at("longitude_deg").get<double>(),
                o.at("altitude_m").get<double>()};
    c.gyro_period = j.at("gyro_period_s").get<double>();
  } catch (const json::exception& e) {
    throw io::InputError(origin + ": " + e.what());
  }
  validateCameras(c.cameras, origin);
  if (!(c.gyro_period > 0)) throw io::InputError(origin + ": gyro_period_s must be positive");
  return c;
}

DatasetWriter::DatasetWriter(fs::path dir, const RigCalibration& calibration, const LaserCalibration& lasers,
                             std::string producer_json, bool force)
    : dir_(std::move(dir)), producer_json_(std::move(producer_json)) {
  io::prepareOutputDir(dir_, force);
  fs::create_directories(dir_ / "lidar");
  validateCameras(calibration.cameras, "rig calibration");
  for (const auto& c : calibration.cameras) {
    fs::create_directories(dir_ / "camera" / c.name);
    camera_names_.push_back(c.name);
  }
  // a stale manifest from an earlier recording would describe other data
  std::error_code ec;
  fs::remove(dir_ / "manifest.json", ec);
  io::writeFileAtomic(dir_ / "calibration.json", calibrationToJson(calibration), true);
  io::writeFileAtomic(dir_ / "lasers.yaml", laserCalibrationToYaml(lasers), true);
  frames_.open(dir_ / "frames.csv", std::ios::trunc);
  gps_.open(dir_ / "gps.csv", std::ios::trunc);
  gyro_.open(dir_ / "gyro.csv", std::ios::trunc);
  poses_.open(dir_ / "poses_gt.csv", std::ios::trunc);
  if (!frames_ || !gps_ || !gyro_ || !poses_) throw io::InputError(dir_.string() + ": cannot create CSV files");
  frames_ << "frame,sweep_start_s,sweep_end_s,camera_time_s,points\n";
  gps_ << "time_s,latitude_deg,longitude_deg,altitude_m,sigma_m\n";
  gyro_ << "time_s,wx_rad_s,wy_rad_s,wz_rad_s\n";
  poses_ << "time_s,x_m,y_m,z_m,qw,qx,qy,qz\n";
}

DatasetWriter::~DatasetWriter() = default;

void DatasetWriter::write(const RigFrame& frame) {
  const SensorFrame& s = frame.sensors;
  const int k = s.index;
  has_truth_ = has_truth_ || frame.truth.has_value();
  static const std::vector<PointTruth> kNoTruth;
  io::writeFileAtomic(dir_ / "lidar" / frameName(k, ".pcd"),
                      encodePcd(s.sweep, frame.truth ? frame.truth->points : kNoTruth), true);
  for (const CameraImage& image : s.images) {
    if (image.camera < 0 || image.camera >= static_cast<int>(camera_names_.size()))
      throw io::InputError(dir_.string() + ": frame " + std::to_string(k) + " has an image of camera " +
                           std::to_string(image.camera) + ", which the calibration does not list");
    if (image.time != s.images.front().time)
      throw io::InputError(dir_.string() + ": frame " + std::to_string(k) +
                           ": the cameras' images were not taken together (a dataset keeps one camera time per frame)");
    cv::Mat bgr;
    cv::cvtColor(image.rgb, bgr, cv::COLOR_RGB2BGR);
    writeImage(dir_ / "camera" / camera_names_[image.camera] / frameName(k, ".png"), bgr);
  }
  if (frame.truth) {
    for (const CameraTruth& t : frame.truth->cameras) {
      if (t.camera < 0 || t.camera >= static_cast<int>(camera_names_.size())) continue;
      const fs::path folder = dir_ / "camera" / camera_names_[t.camera];
      if (!t.depth.empty()) writeImage(folder / frameName(k, "_depth.tiff"), t.depth);
      if (!t.segmentation.empty()) writeImage(folder / frameName(k, "_seg.png"), t.segmentation);
    }
  }
  frames_ << k << ',' << g17(s.sweep.start_time) << ',' << g17(s.sweep.end_time) << ','
          << (s.images.empty() ? std::string("nan") : g17(s.images.front().time)) << ',' << s.sweep.points.size()
          << '\n';
  for (const auto& f : s.gps) {
    gps_ << g17(f.time) << ',' << g17(f.latitude_deg) << ',' << g17(f.longitude_deg) << ',' << g17(f.altitude_m) << ','
         << g17(f.sigma_m) << '\n';
  }
  for (const auto& g : s.gyro)
    gyro_ << g17(g.time) << ',' << g17(g.rate.x()) << ',' << g17(g.rate.y()) << ',' << g17(g.rate.z()) << '\n';
  if (frame.truth) {
    for (const auto& p : frame.truth->poses) {
      const Eigen::Quaterniond q(p.world_from_vehicle.rotation());
      const Vector3 t = p.world_from_vehicle.translation();
      poses_ << g17(p.time) << ',' << g17(t.x()) << ',' << g17(t.y()) << ',' << g17(t.z()) << ',' << g17(q.w()) << ','
             << g17(q.x()) << ',' << g17(q.y()) << ',' << g17(q.z()) << '\n';
    }
  }
  for (auto* f : {&frames_, &gps_, &gyro_, &poses_}) f->flush();
  ++count_;
}

void DatasetWriter::finish() {
  if (finished_) return;
  finished_ = true;
  for (auto* f : {&frames_, &gps_, &gyro_, &poses_}) f->close();
  json m;
  m["format"] = kDatasetFormat;
  m["frames"] = count_;
  m["ground_truth"] = has_truth_;
  m["cameras"] = camera_names_;
  m["producer"] = producer_json_.empty() ? json::object() : json::parse(producer_json_);
  m["frames_and_units"] =
      "world: ENU (x east, y north, z up) at calibration.json geodetic_origin; vehicle: x forward, y left, z up, "
      "origin on the ground under the robot; lidar: x forward, y left, z up; camera: x right, y down, z forward. "
      "Metres, radians, seconds.";
  m["files"] = {
      {"calibration.json",
       "cameras (name, intrinsics [px], 4x4 row-major vehicle_from_camera), 4x4 row-major "
       "extrinsics vehicle_from_{lidar,gps}, geodetic origin of the world frame, gyro period [s]"},
      {"lasers.yaml", "laser table in ROS velodyne driver YAML (vert_correction, rot_correction [rad], offsets [m])"},
      {"frames.csv",
       "one row per frame: frame, sweep_start_s, sweep_end_s, camera_time_s (every camera's exposure; "
       "nan: no images), points"},
      {"lidar/NNNNNN.pcd",
       "binary PCD, one per sweep: x y z [m, lidar frame at the firing time] float32, "
       "intensity [0-255] float32, ring (laser id) uint16, azimuth [rad, encoder] float32, "
       "time [s] float64, label (geom id hit, -1 none) int32, class (0 none, 1 ground, 2 building, "
       "3 trunk, 4 crown, 5 robot) uint8"},
      {"camera/NAME/NNNNNN.png", "RGB image of camera NAME (manifest 'cameras'), 8 bit"},
      {"camera/NAME/NNNNNN_depth.tiff", "ground truth depth along the optical axis [m], float32, 0 = nothing hit"},
      {"camera/NAME/NNNNNN_seg.png", "ground truth segmentation, uint16 = geom id + 1, 0 = sky"},
      {"gps.csv", "time_s, latitude_deg, longitude_deg, altitude_m (WGS84 ellipsoid), sigma_m"},
      {"gyro.csv",
       "time_s, wx_rad_s, wy_rad_s, wz_rad_s: mean angular rate over the preceding gyro period, vehicle frame"},
      {"poses_gt.csv", "ground truth world_from_vehicle: time_s, x_m, y_m, z_m, qw, qx, qy, qz"}};
  io::writeFileAtomic(dir_ / "manifest.json", m.dump(1) + "\n", true);
}

DatasetSource::DatasetSource(fs::path dir) : dir_(std::move(dir)) {
  if (!fs::is_directory(dir_)) throw io::InputError(dir_.string() + ": not a directory");
  const fs::path manifest_path = dir_ / "manifest.json";
  if (!fs::exists(manifest_path)) {
    throw io::InputError(dir_.string() + ": no manifest.json (not a dataset, or the recording did not finish)");
  }
  json m;
  try {
    m = json::parse(io::readFile(manifest_path));
  } catch (const json::parse_error& e) {
    throw io::InputError(manifest_path.string() + ": not valid JSON (" + e.what() + ")");
  }
  const std::string format =
      m.is_object() && m.contains("format") && m["format"].is_string() ? m["format"].get<std::string>() : "";
  if (format != kDatasetFormat && format != kDatasetFormatV1) {
    throw io::InputError(manifest_path.string() + ": 'format' must be " + kDatasetFormat + " (or the older " +
                         kDatasetFormatV1 + ")");
  }
  format_version_ = format == kDatasetFormat ? 2 : 1;
  has_truth_ = m.value("ground_truth", false);
  producer_json_ = m.contains("producer") ? m["producer"].dump() : "{}";
  calibration_ = calibrationFromJson(io::readFile(dir_ / "calibration.json"), (dir_ / "calibration.json").string());
  lasers_ = loadLaserCalibration(dir_ / "lasers.yaml");
  // where each camera's images are: format 1 kept its one camera's images in camera/ itself
  if (format_version_ == 1) {
    if (calibration_.cameras.size() != 1)
      throw io::InputError((dir_ / "calibration.json").string() + ": a format-1 dataset has exactly one camera");
    camera_dirs_.push_back(dir_ / "camera");
  } else {
    std::vector<std::string> names;
    try {
      names = m.at("cameras").get<std::vector<std::string>>();
    } catch (const json::exception&) {
      throw io::InputError(manifest_path.string() + ": 'cameras' must list the cameras' names");
    }
    std::vector<std::string> calibrated;
    for (const auto& c : calibration_.cameras) calibrated.push_back(c.name);
    if (names != calibrated)
      throw io::InputError(manifest_path.string() + ": 'cameras' does not match the cameras of calibration.json");
    for (const auto& n : names) {
      if (!fs::is_directory(dir_ / "camera" / n))
        throw io::InputError(manifest_path.string() + ": camera '" + n + "' has no images (no folder camera/" + n +
                             "/)");
      camera_dirs_.push_back(dir_ / "camera" / n);
    }
  }
  for (const auto& r : readCsv(dir_ / "frames.csv", 5)) {
    frames_.push_back({static_cast<int>(r[0]), r[1], r[2], r[3], !std::isnan(r[3])});
  }
  const int declared = m.value("frames", -1);
  if (declared != static_cast<int>(frames_.size())) {
    throw io::InputError(manifest_path.string() + ": declares " + std::to_string(declared) +
                         " frames, frames.csv has " + std::to_string(frames_.size()));
  }
  const auto gps_row = [](const std::vector<double>& r) -> std::string {
    if (std::abs(r[1]) > 90 || std::abs(r[2]) > 180) return "latitude/longitude outside [-90, 90] / [-180, 180] deg";
    if (std::abs(r[3]) > 1e5) return "altitude beyond 100 km";
    if (r[4] < 0) return "sigma_m is negative";
    return {};
  };
  for (const auto& r : readStream(dir_ / "gps.csv", 5, gps_row)) gps_.push_back({r[0], r[1], r[2], r[3], r[4]});
  for (const auto& r : readStream(dir_ / "gyro.csv", 4, [](const auto&) { return std::string(); })) {
    gyro_.push_back({r[0], Vector3(r[1], r[2], r[3])});
  }
  if (has_truth_) {
    // the vehicle drives forward (the pose estimation takes its heading from the GPS track): over
    // every stretch of at least kStretch (0.5 m), its forward axis at the stretch's end points less
    // than 120 degrees away from the stretch
    constexpr double kStretch = 0.5;
    std::optional<Eigen::Vector2d> stretch_start;
    const auto pose_row = [&stretch_start](const std::vector<double>& r) -> std::string {
      const double norm = Eigen::Vector4d(r[4], r[5], r[6], r[7]).norm();
      if (std::abs(norm - 1.0) > 1e-3) return "the quaternion qw qx qy qz has norm " + std::to_string(norm) + ", not 1";
      // a ground vehicle stands upright: its z axis within 60 degrees of up (roll or pitch beyond
      // that would be a rolled-over robot, or a quaternion in another order)
      const Vector3 up = Eigen::Quaterniond(r[4], r[5], r[6], r[7]).normalized() * Vector3::UnitZ();
      if (up.z() < 0.5) {
        const double degrees = std::acos(std::clamp(up.z(), -1.0, 1.0)) * 180.0 / 3.14159265358979323846;
        return "the vehicle is tilted " + std::to_string(std::lround(degrees)) +
               " degrees from upright (at most 60: roll or pitch of a ground vehicle; is the quaternion in the order "
               "qw qx qy qz?)";
      }
      const Eigen::Vector2d at(r[1], r[2]);
      if (!stretch_start) stretch_start = at;
      const Eigen::Vector2d moved = at - *stretch_start;
      if (moved.norm() < kStretch) return {};
      stretch_start = at;
      const Vector3 ahead = Eigen::Quaterniond(r[4], r[5], r[6], r[7]).normalized() * Vector3::UnitX();
      if (ahead.head<2>().dot(moved) < -0.5 * ahead.head<2>().norm() * moved.norm())
        return "the vehicle drives backwards (its x axis points against its last 0.5 m of motion); the pose "
               "estimation takes the heading from the GPS track, driving forward";
      return {};
    };
    for (const auto& r : readStream(dir_ / "poses_gt.csv", 8, pose_row)) {
      TimedPose p;
      p.time = r[0];
      p.world_from_vehicle = Pose::Identity();
      p.world_from_vehicle.translation() = Vector3(r[1], r[2], r[3]);
      p.world_from_vehicle.linear() = Eigen::Quaterniond(r[4], r[5], r[6], r[7]).normalized().toRotationMatrix();
      poses_.push_back(p);
    }
  }
}

std::optional<RigFrame> DatasetSource::next() {
  if (cursor_ >= frames_.size()) return std::nullopt;
  const FrameRow& row = frames_[cursor_++];
  RigFrame f;
  SensorFrame& s = f.sensors;
  s.index = row.index;
  const fs::path pcd_path = dir_ / "lidar" / frameName(row.index, ".pcd");
  DecodedPcd pcd = decodePcd(io::readFile(pcd_path), pcd_path.string());
  s.sweep.start_time = row.start;
  s.sweep.end_time = row.end;
  s.sweep.points = std::move(pcd.points);
  if (row.has_camera) {
    for (std::size_t c = 0; c < camera_dirs_.size(); ++c) {
      const fs::path image = camera_dirs_[c] / frameName(row.index, ".png");
      if (!fs::exists(image))
        throw io::InputError(image.string() + ": missing: frame " + std::to_string(row.index) +
                             " has a camera time but camera '" + calibration_.cameras[c].name + "' no image");
      CameraImage img;
      img.camera = static_cast<int>(c);
      img.time = row.camera_time;
      img.rgb = readRgbImage(image);
      s.images.push_back(std::move(img));
    }
  }
  s.gps = window(gps_, row.start, row.end);
  s.gyro = window(gyro_, row.start, row.end);
  if (has_truth_) {
    FrameTruth t;
    t.points = std::move(pcd.truth);
    for (std::size_t c = 0; c < camera_dirs_.size() && row.has_camera; ++c) {
      const fs::path depth = camera_dirs_[c] / frameName(row.index, "_depth.tiff");
      const fs::path seg = camera_dirs_[c] / frameName(row.index, "_seg.png");
      CameraTruth camera;
      camera.camera = static_cast<int>(c);
      if (fs::exists(depth)) camera.depth = readImage(depth, cv::IMREAD_UNCHANGED, CV_32FC1);
      if (fs::exists(seg)) camera.segmentation = readImage(seg, cv::IMREAD_UNCHANGED, CV_16UC1);
      if (!camera.depth.empty() || !camera.segmentation.empty()) t.cameras.push_back(std::move(camera));
    }
    t.poses = window(poses_, row.start, row.end);
    f.truth = std::move(t);
  }
  return f;
}

}  // namespace terrain::rig
