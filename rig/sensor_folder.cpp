#include "rig/sensor_folder.hpp"

#include "rig/dataset.hpp"
#include "rig/file_io.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace terrain::rig {

namespace fs = std::filesystem;

namespace {

// camera/NAME/images.csv: a header, then time_s,file per image, times increasing
std::vector<std::pair<double, fs::path>> readImageList(const fs::path& path) {
  std::istringstream in(io::readFile(path));
  std::string line;
  std::getline(in, line);  // header
  std::vector<std::pair<double, fs::path>> out;
  for (int line_no = 2; std::getline(in, line); ++line_no) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const auto where = [&] { return path.string() + ":" + std::to_string(line_no) + ": "; };
    const auto comma = line.find(',');
    if (comma == std::string::npos) throw io::InputError(where() + "expected time_s,file");
    const std::string cell = line.substr(0, comma), file = line.substr(comma + 1);
    const double time = parseCsvNumber(cell, where());
    if (!std::isfinite(time)) throw io::InputError(where() + "the time is not finite");
    if (!out.empty() && time <= out.back().first)
      throw io::InputError(where() + "time does not increase from the row before");
    if (file.empty()) throw io::InputError(where() + "no file named");
    const fs::path image = path.parent_path() / file;
    if (!fs::is_regular_file(image)) throw io::InputError(where() + image.string() + " is not there");
    out.emplace_back(time, image);
  }
  return out;
}

}  // namespace

SensorFolder::SensorFolder(const fs::path& dir) : dir_(dir) {
  if (!fs::is_directory(dir)) throw io::InputError(dir.string() + ": not a directory");
  const fs::path calibration = dir / "calibration.json";
  if (!fs::exists(calibration)) {
    throw io::InputError(dir.string() +
                         ": no calibration.json (the rig calibration: cameras, vehicle_from_lidar, vehicle_from_gps)");
  }
  calibration_ = calibrationFromJson(io::readFile(calibration), calibration.string());
  for (const CameraCalibration& c : calibration_.cameras) {
    const fs::path list = dir / "camera" / c.name / "images.csv";
    if (!fs::exists(list)) {
      throw io::InputError(list.string() + ": missing: calibration.json lists camera '" + c.name +
                           "', whose images this file lists (time_s,file)");
    }
    std::vector<Listed> images;
    for (auto& [time, file] : readImageList(list)) images.push_back({time, std::move(file)});
    images_.push_back(std::move(images));
  }
  if (fs::exists(dir / "gyro.csv")) {
    for (const auto& r : readSensorStream(dir / "gyro.csv", 4)) gyro_.push_back({r[0], Vector3(r[1], r[2], r[3])});
  }
}

std::size_t SensorFolder::images() const {
  std::size_t n = 0;
  for (const auto& list : images_) n += list.size();
  return n;
}

void SensorFolder::fill(SensorFrame& frame, double after, double until) const {
  for (std::size_t c = 0; c < images_.size(); ++c) {
    const auto& list = images_[c];
    // the latest image at or before `until`, if it lies after `after`
    const auto it =
        std::upper_bound(list.begin(), list.end(), until, [](double t, const Listed& image) { return t < image.time; });
    if (it == list.begin() || std::prev(it)->time <= after) continue;
    const Listed& listed = *std::prev(it);
    CameraImage image;
    image.camera = static_cast<int>(c);
    image.time = listed.time;
    image.rgb = readRgbImage(listed.file);
    const CameraIntrinsics& k = calibration_.cameras[c].intrinsics;
    if (image.rgb.cols != k.width || image.rgb.rows != k.height) {
      throw io::InputError(listed.file.string() + ": " + std::to_string(image.rgb.cols) + " x " +
                           std::to_string(image.rgb.rows) + " px, but calibration.json gives camera '" +
                           calibration_.cameras[c].name + "' " + std::to_string(k.width) + " x " +
                           std::to_string(k.height));
    }
    frame.images.push_back(std::move(image));
  }
  const auto first =
      std::upper_bound(gyro_.begin(), gyro_.end(), after, [](double t, const GyroSample& g) { return t < g.time; });
  const auto last =
      std::upper_bound(first, gyro_.end(), until, [](double t, const GyroSample& g) { return t < g.time; });
  frame.gyro.insert(frame.gyro.end(), first, last);
}

}  // namespace terrain::rig
