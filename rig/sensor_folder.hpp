#pragma once
// Camera images and gyro samples recorded beside a real lidar capture, read from a folder, so that
// a capture reconstructed alone ('terrain reconstruct --lidar pcap:FILE --sensors DIR') has the
// rest of the rig. The layout (docs/velodyne.md):
//   calibration.json          the rig calibration in the dataset's format: the cameras (name,
//                             intrinsics, vehicle_from_camera), vehicle_from_lidar,
//                             vehicle_from_gps, gyro_period_s
//   camera/NAME/images.csv    for each camera of the calibration: time_s,file per image, times in
//                             the capture's clock (as 'terrain lidar inspect' prints it), files
//                             relative to the folder camera/NAME/
//   gyro.csv                  optional: time_s, wx_rad_s, wy_rad_s, wz_rad_s, the mean angular rate
//                             over the preceding gyro period in the vehicle frame

#include "core/sensor_data.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace terrain::rig {

class SensorFolder {
 public:
  // Reads and checks the listing files (every listed image must exist; images are decoded when
  // handed out). Throws io::InputError naming the file, and the line where there is one.
  explicit SensorFolder(const std::filesystem::path& dir);

  // The calibration as read; its origin is left for the lidar's first GPS fix.
  const RigCalibration& calibration() const { return calibration_; }
  // Adds to `frame` each camera's latest image and every gyro sample whose time lies in
  // (after, until]. Throws io::InputError for an image that does not decode or whose size is not
  // its camera's.
  void fill(SensorFrame& frame, double after, double until) const;

  std::size_t images() const;  // listed, over every camera
  std::size_t gyroSamples() const { return gyro_.size(); }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  struct Listed {
    double time;
    std::filesystem::path file;
  };
  std::filesystem::path dir_;
  RigCalibration calibration_;
  std::vector<std::vector<Listed>> images_;  // by camera, in time order
  std::vector<GyroSample> gyro_;
};

}  // namespace terrain::rig
