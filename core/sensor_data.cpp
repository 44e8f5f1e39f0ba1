#include "core/sensor_data.hpp"

#include <cmath>

namespace terrain {

CameraIntrinsics CameraIntrinsics::fromFovy(int width, int height, double fovy) {
  CameraIntrinsics k;
  k.width = width;
  k.height = height;
  // square pixels: the vertical field of view fixes both focal lengths
  k.fy = 0.5 * height / std::tan(0.5 * fovy);
  k.fx = k.fy;
  k.cx = 0.5 * width;
  k.cy = 0.5 * height;
  return k;
}

int cameraIndex(const RigCalibration& calibration, const std::string& name) {
  for (std::size_t i = 0; i < calibration.cameras.size(); ++i) {
    if (calibration.cameras[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace terrain
