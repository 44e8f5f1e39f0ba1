// The files a reconstruction writes: a mesh wider than the images' pixel limit is drawn coarser,
// with a warning, instead of allocating an image per cell over its whole extent.

#include "app/outputs.hpp"
#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <memory>

namespace terrain {
namespace {

// a pipeline holding two 3 x 3 patches of cells (0.2 m), `apart` cells apart along x
std::unique_ptr<Pipeline> twoPatches(int apart) {
  auto p = std::make_unique<Pipeline>(RigCalibration{}, PipelineConfig{});
  std::vector<Voxel> voxels;
  std::vector<MeshVertex> vertices;
  for (const int x0 : {0, apart}) {
    for (int x = x0; x < x0 + 3; ++x) {
      for (int y = 0; y < 3; ++y) {
        Voxel v;
        v.index = VoxelIndex(x, y, 5);
        v.height = 1.1f + 0.01f * y;
        v.label = VoxelLabel::Ground;
        MeshVertex m;
        m.cell = CellIndex(x, y);
        m.top_voxel = static_cast<std::uint32_t>(voxels.size());
        m.sensed_height = v.height;
        voxels.push_back(v);
        vertices.push_back(m);
      }
    }
  }
  SegmentationResult seg;
  seg.rough.assign(voxels.size(), 1);
  seg.refined.assign(voxels.size(), 1);
  seg.ground_height.assign(voxels.size(), 1.1f);
  EXPECT_TRUE(p->restore(voxels, vertices, seg, {}));
  return p;
}

TEST(OutputsTest, AMeshWiderThanTheImageLimitIsDrawnCoarserWithAWarning) {
  test::TempDir dir;
  // 2 km: 10,003 cells across, 3 cells a pixel
  app::writeReconstruction(dir.path(), *twoPatches(10000));
  const cv::Mat tex = cv::imread((dir / "mesh_texture.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(tex.cols, 3335);
  EXPECT_EQ(tex.rows, 1);
  const cv::Mat map = cv::imread((dir / "height_before.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_GT(map.cols, 3335);
  EXPECT_LT(map.cols, 3335 + 400);  // the map and its scale bar
  const std::string warnings = io::readFile(dir / "warnings.json");
  EXPECT_NE(warnings.find("0.6 m per pixel"), std::string::npos) << warnings;
  // the texture coordinates of the far patch's last cell: (10002 + 0.5) / (3335 * 3), in the last texel
  const std::string obj = io::readFile(dir / "mesh.obj");
  EXPECT_NE(obj.find("vt 0.999750 0.833333"), std::string::npos);
}

TEST(OutputsTest, AMeshWithinTheImageLimitIsDrawnACellAPixel) {
  test::TempDir dir;
  app::writeReconstruction(dir.path(), *twoPatches(100));
  const cv::Mat tex = cv::imread((dir / "mesh_texture.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(tex.cols, 103);
  EXPECT_EQ(tex.rows, 3);
  EXPECT_EQ(io::readFile(dir / "warnings.json").find("per pixel"), std::string::npos);
}

}  // namespace
}  // namespace terrain
