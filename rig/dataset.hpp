#pragma once
// Recorded datasets: a directory with one file per sweep and camera frame, CSV streams for GPS,
// gyro and true poses, the rig calibration and a manifest.json that documents every file with
// its units. The layout is described in README.md ("Dataset format").

#include "rig/sensor_source.hpp"

#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace terrain::rig {

// Format 2 keeps each camera's images under camera/NAME/; format 1 (one camera, its images in
// camera/) still loads, its camera named kLegacyCameraName.
inline constexpr const char* kDatasetFormat = "terrain-dataset/2";
inline constexpr const char* kDatasetFormatV1 = "terrain-dataset/1";
inline constexpr const char* kLegacyCameraName = "front";

// Writes frames as they come. Each file is written whole or not at all; the manifest is written
// last, so a dataset without one is known to be incomplete.
class DatasetWriter {
 public:
  // Creates dir (refusing a non-empty one unless force) and writes the calibration.
  // producer_json: a JSON object describing how the data was made (scene, settings), kept in the
  // manifest as "producer".
  DatasetWriter(std::filesystem::path dir, const RigCalibration& calibration, const LaserCalibration& lasers,
                std::string producer_json, bool force);
  ~DatasetWriter();

  void write(const RigFrame& frame);
  // Writes the manifest. Without it the dataset does not load.
  void finish();

 private:
  std::filesystem::path dir_;
  std::string producer_json_;
  std::ofstream frames_, gps_, gyro_, poses_;
  int count_ = 0;
  std::vector<std::string> camera_names_;  // by camera index
  bool has_truth_ = false;
  bool finished_ = false;
};

// Reads a dataset back frame for frame as it was written.
class DatasetSource : public SensorSource {
 public:
  // Reads the manifest, calibration and CSV streams; throws io::InputError naming the file.
  explicit DatasetSource(std::filesystem::path dir);

  const RigCalibration& calibration() const override { return calibration_; }
  const LaserCalibration& lasers() const override { return lasers_; }
  std::optional<RigFrame> next() override;
  int frameCount() const override { return static_cast<int>(frames_.size()); }

  // the manifest's "producer" object, as JSON text
  const std::string& producerJson() const { return producer_json_; }
  // the dataset's format version (1 or 2)
  int formatVersion() const { return format_version_; }

 private:
  struct FrameRow {
    int index;
    double start, end, camera_time;
    bool has_camera;
  };
  std::filesystem::path dir_;
  RigCalibration calibration_;
  LaserCalibration lasers_;
  std::vector<FrameRow> frames_;
  std::vector<GpsFix> gps_;
  std::vector<GyroSample> gyro_;
  std::vector<TimedPose> poses_;
  std::string producer_json_;
  std::vector<std::filesystem::path> camera_dirs_;  // by camera index
  int format_version_ = 2;
  bool has_truth_ = false;
  std::size_t cursor_ = 0;
};

// JSON text of a rig calibration (4x4 row-major extrinsics, intrinsics in pixels), and back; the
// reader also takes format 1's single "camera" and "vehicle_from_camera". Throws io::InputError
// naming `origin` for a malformed calibration (see validateCameras).
std::string calibrationToJson(const RigCalibration& calibration);
RigCalibration calibrationFromJson(const std::string& text, const std::string& origin);

// A CSV cell as a number, the whole cell; throws io::InputError "<where>'<cell>' is not a number".
double parseCsvNumber(const std::string& cell, const std::string& where);
// The rows of a CSV sensor stream after its header line: `columns` numbers each, every value
// finite, times (the first column) increasing, and what `check` says of each row (empty: fine).
// Throws io::InputError naming the file and line.
std::vector<std::vector<double>> readSensorStream(
    const std::filesystem::path& path, std::size_t columns,
    const std::function<std::string(const std::vector<double>&)>& check = {});
// An 8-bit colour image file, RGB order; throws io::InputError naming the file if it is not one.
cv::Mat readRgbImage(const std::filesystem::path& path);

// Throws io::InputError naming `origin` and the camera for a camera without a name or with one that
// cannot name a folder, a duplicate name, or intrinsics or an extrinsic that are not positive and finite.
void validateCameras(const std::vector<CameraCalibration>& cameras, const std::string& origin);

}  // namespace terrain::rig
