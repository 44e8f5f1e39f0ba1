#include "sim/camera.hpp"

#include "rig/file_io.hpp"

#include <GL/osmesa.h>

#include <algorithm>
#include <cstring>
#include <utility>
#include <vector>

namespace terrain::sim {

struct CameraRenderer::Gl {
  OSMesaContext context = nullptr;
  std::vector<unsigned char> buffer;
  mjvScene scene;
  mjrContext render;
  mjvOption option;
  mjvCamera camera;
};

CameraRenderer::CameraRenderer(const World& world, const CameraMount& config)
    : world_(world), config_(config), gl_(std::make_unique<Gl>()) {
  model_ = mj_copyModel(nullptr, world.model());
  camera_ = mj_name2id(model_, mjOBJ_CAMERA, "robot_camera");
  if (camera_ < 0) {
    throw io::InputError(
        "scene has no camera named 'robot_camera': the simulated rig renders every camera of the rig through it, "
        "placing it at each camera's pose; add <camera name=\"robot_camera\" pos=\"0.1 0 1.6\" xyaxes=\"0 -1 0 0 0 "
        "1\"/> to the robot's body (<body name=\"robot\" mocap=\"true\">), as generated scenes have it, or record "
        "with --no-camera");
  }
  model_->cam_fovy[camera_] = config.fovy_deg;
  model_->vis.global.offwidth = config.width;
  model_->vis.global.offheight = config.height;
  model_->vis.quality.offsamples = 0;  // multisampling would blend depth and segmentation at edges
  data_ = mj_makeData(model_);
  mj_forward(model_, data_);

  gl_->context = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 8, nullptr);
  if (!gl_->context) throw io::InputError("OSMesa could not create an offscreen context");
  gl_->buffer.resize(static_cast<std::size_t>(config.width) * config.height * 4);
  if (!OSMesaMakeCurrent(gl_->context, gl_->buffer.data(), GL_UNSIGNED_BYTE, config.width, config.height)) {
    throw io::InputError("OSMesa could not make its context current");
  }
  mjv_defaultScene(&gl_->scene);
  mjv_makeScene(model_, &gl_->scene, model_->ngeom + 100);
  mjr_defaultContext(&gl_->render);
  mjr_makeContext(model_, &gl_->render, mjFONTSCALE_100);
  mjr_setBuffer(mjFB_OFFSCREEN, &gl_->render);
  mjv_defaultOption(&gl_->option);
  mjv_defaultCamera(&gl_->camera);
  gl_->camera.type = mjCAMERA_FIXED;
  gl_->camera.fixedcamid = camera_;
}

CameraRenderer::~CameraRenderer() {
  if (gl_ && gl_->context) {
    OSMesaMakeCurrent(gl_->context, gl_->buffer.data(), GL_UNSIGNED_BYTE, config_.width, config_.height);
    mjr_freeContext(&gl_->render);
    mjv_freeScene(&gl_->scene);
    OSMesaDestroyContext(gl_->context);
  }
  if (data_) mj_deleteData(data_);
  if (model_) mj_deleteModel(model_);
}

CameraIntrinsics CameraRenderer::intrinsics() const {
  return CameraIntrinsics::fromFovy(config_.width, config_.height, config_.fovy_deg * 3.14159265358979323846 / 180.0);
}

CameraRender CameraRenderer::render(const Pose& world_from_camera) {
  const int w = config_.width, h = config_.height;
  OSMesaMakeCurrent(gl_->context, gl_->buffer.data(), GL_UNSIGNED_BYTE, w, h);
  // MuJoCo cameras look along -z with y up: flip the y and z axes of the OpenCV-style frame
  const Eigen::Matrix3d r = world_from_camera.linear();
  Eigen::Matrix3d mj;
  mj.col(0) = r.col(0);
  mj.col(1) = -r.col(1);
  mj.col(2) = -r.col(2);
  for (int i = 0; i < 3; ++i) {
    data_->cam_xpos[3 * camera_ + i] = world_from_camera.translation()[i];
    for (int j = 0; j < 3; ++j) data_->cam_xmat[9 * camera_ + 3 * i + j] = mj(i, j);
  }
  const mjrRect viewport{0, 0, w, h};
  mjvScene& scene = gl_->scene;
  mjv_updateScene(model_, data_, &gl_->option, nullptr, &gl_->camera, mjCAT_ALL, &scene);
  // mjv_updateScene recomputes nothing of the camera pose: it reads cam_xpos / cam_xmat
  //
  // The terrain's heightfield (a hundred thousand cells) costs most of a frame, so it is drawn
  // once. The first pass draws every geom without the skybox: a pixel it leaves at the far plane
  // saw the sky, which a pass of the skybox alone then colours. The segmentation pass draws every
  // geom but the terrain in the colour of its segmentation id + 1: a pixel whose nearest such geom
  // lies behind what the first pass saw there (or that has none) saw the terrain. Geoms drawn in
  // both passes rasterise to the same depths. With one pass of each kind instead (the terrain in
  // both, the skybox in the first), the images are the same.
  int terrain = -1, heightfields = 0;
  for (int i = 0; i < scene.ngeom; ++i) {
    if (scene.geoms[i].type == mjGEOM_HFIELD) terrain = i, ++heightfields;
  }
  const bool once = heightfields == 1 && !segmentation_pass_with_terrain_;
  const std::size_t pixels = static_cast<std::size_t>(w) * h;
  std::vector<unsigned char> rgb(pixels * 3);
  std::vector<float> depth(pixels);
  scene.flags[mjRND_SEGMENT] = 0;
  scene.flags[mjRND_IDCOLOR] = 0;
  const mjtByte skybox = scene.flags[mjRND_SKYBOX];
  if (once) scene.flags[mjRND_SKYBOX] = 0;
  mjr_render(viewport, &scene, &gl_->render);
  mjr_readPixels(rgb.data(), depth.data(), viewport, &gl_->render);
  scene.flags[mjRND_SKYBOX] = skybox;
  if (once && skybox && std::any_of(depth.begin(), depth.end(), [](float d) { return d >= 1.0f; })) {
    std::vector<unsigned char> sky(pixels * 3);
    const int ngeom = scene.ngeom;
    scene.ngeom = 0;
    mjr_render(viewport, &scene, &gl_->render);
    mjr_readPixels(sky.data(), nullptr, viewport, &gl_->render);
    scene.ngeom = ngeom;
    for (std::size_t i = 0; i < pixels; ++i) {
      if (depth[i] >= 1.0f) std::memcpy(&rgb[3 * i], &sky[3 * i], 3);
    }
  }
  // OpenGL rows run bottom-up
  CameraRender out;
  out.rgb.create(h, w, CV_8UC3);
  out.depth.create(h, w, CV_32FC1);
  const double extent = model_->stat.extent;
  const double znear = model_->vis.map.znear * extent, zfar = model_->vis.map.zfar * extent;
  for (int y = 0; y < h; ++y) {
    std::memcpy(out.rgb.ptr(y), rgb.data() + static_cast<std::size_t>(h - 1 - y) * w * 3,
                static_cast<std::size_t>(w) * 3);
    const float* src = depth.data() + static_cast<std::size_t>(h - 1 - y) * w;
    float* dst = out.depth.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      // window depth in [0, 1] back to distance along the optical axis
      const double d = src[x];
      dst[x] = d >= 1.0 ? 0.0f : static_cast<float>(znear * zfar / (zfar - d * (zfar - znear)));
    }
  }
  // the value of each segmentation id: its geom's id + 1, 0 for what is not a model geom
  std::vector<std::uint16_t> value_of(static_cast<std::size_t>(scene.ngeom), 0);
  for (int i = 0; i < scene.ngeom; ++i) {
    const mjvGeom& g = scene.geoms[i];
    if (g.segid >= 0 && g.segid < scene.ngeom && g.objtype == mjOBJ_GEOM && g.objid >= 0)
      value_of[g.segid] = static_cast<std::uint16_t>(g.objid + 1);
  }
  std::uint16_t terrain_value = 0;
  if (once) {
    const mjvGeom& g = scene.geoms[terrain];
    if (g.objtype == mjOBJ_GEOM && g.objid >= 0) terrain_value = static_cast<std::uint16_t>(g.objid + 1);
    std::swap(scene.geoms[terrain], scene.geoms[scene.ngeom - 1]);
    --scene.ngeom;
  }
  std::vector<float> depth_objects(once ? pixels : 0);
  scene.flags[mjRND_SEGMENT] = 1;
  scene.flags[mjRND_IDCOLOR] = 1;
  mjr_render(viewport, &scene, &gl_->render);
  mjr_readPixels(rgb.data(), once ? depth_objects.data() : nullptr, viewport, &gl_->render);
  scene.flags[mjRND_SEGMENT] = 0;
  scene.flags[mjRND_IDCOLOR] = 0;
  if (once) {
    ++scene.ngeom;
    std::swap(scene.geoms[terrain], scene.geoms[scene.ngeom - 1]);
  }
  out.segmentation.create(h, w, CV_16UC1);
  for (int y = 0; y < h; ++y) {
    const std::size_t row = static_cast<std::size_t>(h - 1 - y) * w;
    const unsigned char* src = rgb.data() + row * 3;
    auto* dst = out.segmentation.ptr<std::uint16_t>(y);
    for (int x = 0; x < w; ++x) {
      const int segid = (src[3 * x] | (src[3 * x + 1] << 8) | (src[3 * x + 2] << 16)) - 1;
      std::uint16_t value = 0;
      if (once && (segid < 0 || depth_objects[row + x] > depth[row + x])) {
        value = depth[row + x] < 1.0f ? terrain_value : 0;
      } else if (segid >= 0 && segid < static_cast<int>(value_of.size())) {
        value = value_of[segid];
      }
      dst[x] = value;
    }
  }
  return out;
}

}  // namespace terrain::sim
