#pragma once
// Offscreen camera rendered with OSMesa through MuJoCo's renderer: RGB, exact depth along the
// optical axis and a segmentation image of geom ids. Not thread-safe: one renderer per thread.

#include "core/sensor_data.hpp"
#include "sim/sim_config.hpp"
#include "sim/world.hpp"

#include <opencv2/core/mat.hpp>

#include <memory>

namespace terrain::sim {

struct CameraRender {
  cv::Mat rgb;           // CV_8UC3, RGB, row 0 at the top
  cv::Mat depth;         // CV_32FC1 [m] along the optical axis, 0 for sky
  cv::Mat segmentation;  // CV_16UC1 geom id + 1, 0 for sky
};

class CameraRenderer {
 public:
  // Needs a camera named "robot_camera" in the scene. Throws io::InputError if the scene has none
  // or OSMesa cannot create a context.
  CameraRenderer(const World& world, const CameraMount& config);
  ~CameraRenderer();
  CameraRenderer(const CameraRenderer&) = delete;
  CameraRenderer& operator=(const CameraRenderer&) = delete;

  // Renders the view of a camera at world_from_camera (camera frame x right, y down, z forward).
  CameraRender render(const Pose& world_from_camera);

  CameraIntrinsics intrinsics() const;

  // Renders with the straightforward passes instead: the skybox in the first, the terrain in the
  // segmentation pass too (slower; the same images, kept as the reference they are tested against).
  void setSegmentationPassWithTerrain(bool on) { segmentation_pass_with_terrain_ = on; }

 private:
  struct Gl;
  const World& world_;
  CameraMount config_;
  bool segmentation_pass_with_terrain_ = false;
  mjModel* model_ = nullptr;  // own copy: fovy and buffer size follow the config
  mjData* data_ = nullptr;
  int camera_ = -1;
  std::unique_ptr<Gl> gl_;
};

}  // namespace terrain::sim
