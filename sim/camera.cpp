#include "sim/camera.hpp"

#include "rig/file_io.hpp"

#include <GL/osmesa.h>

#include <cstring>
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

CameraRenderer::CameraRenderer(const World& world, const CameraConfig& config)
    : world_(world), config_(config), gl_(std::make_unique<Gl>()) {
  model_ = mj_copyModel(nullptr, world.model());
  camera_ = mj_name2id(model_, mjOBJ_CAMERA, "robot_camera");
  if (camera_ < 0) throw io::InputError("scene has no camera named 'robot_camera'");
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
  mjv_updateScene(model_, data_, &gl_->option, nullptr, &gl_->camera, mjCAT_ALL, &gl_->scene);
  // mjv_updateScene recomputes nothing of the camera pose: it reads cam_xpos / cam_xmat
  CameraRender out;
  std::vector<unsigned char> rgb(static_cast<std::size_t>(w) * h * 3);
  std::vector<float> depth(static_cast<std::size_t>(w) * h);
  gl_->scene.flags[mjRND_SEGMENT] = 0;
  gl_->scene.flags[mjRND_IDCOLOR] = 0;
  mjr_render(viewport, &gl_->scene, &gl_->render);
  mjr_readPixels(rgb.data(), depth.data(), viewport, &gl_->render);
  // OpenGL rows run bottom-up
  out.rgb.create(h, w, CV_8UC3);
  out.depth.create(h, w, CV_32FC1);
  const double extent = model_->stat.extent;
  const double znear = model_->vis.map.znear * extent, zfar = model_->vis.map.zfar * extent;
  for (int y = 0; y < h; ++y) {
    std::memcpy(out.rgb.ptr(y), rgb.data() + static_cast<std::size_t>(h - 1 - y) * w * 3, static_cast<std::size_t>(w) * 3);
    const float* src = depth.data() + static_cast<std::size_t>(h - 1 - y) * w;
    float* dst = out.depth.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      // window depth in [0, 1] back to distance along the optical axis
      const double d = src[x];
      dst[x] = d >= 1.0 ? 0.0f : static_cast<float>(znear * zfar / (zfar - d * (zfar - znear)));
    }
  }
  // segmentation: each geom drawn in the colour segid + 1
  gl_->scene.flags[mjRND_SEGMENT] = 1;
  gl_->scene.flags[mjRND_IDCOLOR] = 1;
  mjr_render(viewport, &gl_->scene, &gl_->render);
  mjr_readPixels(rgb.data(), nullptr, viewport, &gl_->render);
  gl_->scene.flags[mjRND_SEGMENT] = 0;
  gl_->scene.flags[mjRND_IDCOLOR] = 0;
  out.segmentation.create(h, w, CV_16UC1);
  for (int y = 0; y < h; ++y) {
    const unsigned char* src = rgb.data() + static_cast<std::size_t>(h - 1 - y) * w * 3;
    auto* dst = out.segmentation.ptr<std::uint16_t>(y);
    for (int x = 0; x < w; ++x) {
      const int segid = (src[3 * x] | (src[3 * x + 1] << 8) | (src[3 * x + 2] << 16)) - 1;
      std::uint16_t value = 0;
      if (segid >= 0 && segid < gl_->scene.ngeom) {
        const mjvGeom& g = gl_->scene.geoms[segid];
        if (g.objtype == mjOBJ_GEOM && g.objid >= 0) value = static_cast<std::uint16_t>(g.objid + 1);
      }
      dst[x] = value;
    }
  }
  return out;
}

}  // namespace terrain::sim
