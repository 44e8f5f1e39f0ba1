// mesh.glb read back by a reader written from the glTF 2.0 specification: the header and the two
// chunks, every accessor against its buffer view, the bounds against the data, the frame.

#include "app/gltf.hpp"

#include "app/outputs.hpp"
#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>

namespace terrain::app {
namespace {

struct Glb {
  nlohmann::json json;
  std::string bin;
};

std::uint32_t u32(const std::string& s, std::size_t at) {
  std::uint32_t v = 0;
  std::memcpy(&v, s.data() + at, 4);
  return v;
}

// Parses a .glb, checking what a validator checks of its structure; fails the test on any breach.
Glb readGlb(const std::string& bytes) {
  Glb g;
  EXPECT_GE(bytes.size(), 28u);
  if (bytes.size() < 28) return g;
  EXPECT_EQ(u32(bytes, 0), 0x46546C67u);  // "glTF"
  EXPECT_EQ(u32(bytes, 4), 2u);
  EXPECT_EQ(u32(bytes, 8), bytes.size());
  const std::uint32_t json_len = u32(bytes, 12);
  EXPECT_EQ(u32(bytes, 16), 0x4E4F534Au);  // "JSON"
  EXPECT_EQ(json_len % 4, 0u);
  g.json = nlohmann::json::parse(bytes.substr(20, json_len));
  const std::size_t bin_at = 20 + json_len;
  const std::uint32_t bin_len = u32(bytes, bin_at);
  EXPECT_EQ(u32(bytes, bin_at + 4), 0x004E4942u);  // "BIN\0"
  EXPECT_EQ(bin_len % 4, 0u);
  EXPECT_EQ(bin_at + 8 + bin_len, bytes.size());
  g.bin = bytes.substr(bin_at + 8, bin_len);
  EXPECT_EQ(g.json["asset"]["version"], "2.0");
  EXPECT_EQ(g.json["buffers"][0]["byteLength"].get<std::size_t>(), g.bin.size());
  // every accessor fits its view, every vertex attribute is 4-byte aligned, every view its buffer
  for (const auto& v : g.json["bufferViews"]) {
    EXPECT_LE(v["byteOffset"].get<std::size_t>() + v["byteLength"].get<std::size_t>(), g.bin.size());
    EXPECT_EQ(v["byteOffset"].get<std::size_t>() % 4, 0u);
  }
  for (const auto& a : g.json["accessors"]) {
    const auto& v = g.json["bufferViews"][a["bufferView"].get<int>()];
    const int comp = a["componentType"];
    const std::size_t size = comp == 5121 ? 1 : 4;
    const std::string type = a["type"];
    const std::size_t per = type == "VEC3" ? 3 : type == "VEC4" ? 4 : 1;
    EXPECT_EQ(a["count"].get<std::size_t>() * per * size, v["byteLength"].get<std::size_t>()) << a.dump();
  }
  return g;
}

std::vector<float> floats(const Glb& g, int accessor) {
  const auto& a = g.json["accessors"][accessor];
  const auto& v = g.json["bufferViews"][a["bufferView"].get<int>()];
  std::vector<float> out(v["byteLength"].get<std::size_t>() / 4);
  std::memcpy(out.data(), g.bin.data() + v["byteOffset"].get<std::size_t>(), out.size() * 4);
  return out;
}

TEST(GltfTest, AHandMadeMeshReadsBackInGltfsFrame) {
  // two triangles over a 1 m square in the world, the corner (1, 1) raised 2 m
  GlbMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 2}};
  m.colours = {{{255, 0, 0}}, {{0, 255, 0}}, {{0, 0, 255}}, {{255, 220, 0}}};
  m.triangles = {{{0, 1, 2}}, {{1, 3, 2}}};
  const Glb g = readGlb(encodeGlb(m));
  const auto& prim = g.json["meshes"][0]["primitives"][0];
  ASSERT_EQ(prim["attributes"]["POSITION"], 0);
  const auto pos = floats(g, 0);
  ASSERT_EQ(pos.size(), 12u);
  // world (x, y, z) is glTF (x, z, -y)
  EXPECT_FLOAT_EQ(pos[9], 1.0f);
  EXPECT_FLOAT_EQ(pos[10], 2.0f);
  EXPECT_FLOAT_EQ(pos[11], -1.0f);
  EXPECT_FLOAT_EQ(pos[7], 0.0f);
  EXPECT_FLOAT_EQ(pos[8], -1.0f);
  // the bounds are those of the data
  const auto& a = g.json["accessors"][0];
  EXPECT_EQ(a["min"], nlohmann::json({0.0, 0.0, -1.0}));
  EXPECT_EQ(a["max"], nlohmann::json({1.0, 2.0, 0.0}));
  // normals: unit, upwards; vertex 0 is on the flat triangle alone
  const auto nrm = floats(g, 1);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(std::hypot(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]), 1.0, 1e-6);
    EXPECT_GT(nrm[3 * i + 1], 0.0f);
  }
  EXPECT_NEAR(nrm[1], 1.0, 1e-6);
  // colours as RGBA bytes, indices as given
  const auto& colour = g.json["accessors"][2];
  EXPECT_EQ(colour["componentType"], 5121);
  EXPECT_TRUE(colour["normalized"].get<bool>());
  const std::size_t at = g.json["bufferViews"][2]["byteOffset"];
  EXPECT_EQ(static_cast<unsigned char>(g.bin[at + 12]), 255);
  EXPECT_EQ(static_cast<unsigned char>(g.bin[at + 13]), 220);
  EXPECT_EQ(static_cast<unsigned char>(g.bin[at + 15]), 255);
  const std::size_t idx = g.json["bufferViews"][3]["byteOffset"];
  EXPECT_EQ(u32(g.bin, idx + 16), 3u);
  EXPECT_EQ(g.json["accessors"][3]["count"], 6);
}

TEST(GltfTest, EveryReconstructionWritesMeshAndMeshBeforeAsGlb) {
  test::TempDir dir;
  const auto pipeline = test::twoPatches(100);
  writeReconstruction(dir.path(), *pipeline);
  for (const char* name : {"mesh.glb", "mesh_before.glb"}) {
    const Glb g = readGlb(io::readFile(dir / name));
    const auto& a = g.json["accessors"];
    ASSERT_GE(a.size(), 4u) << name;
    const auto pos = floats(g, 0);
    const std::size_t n = a[0]["count"];
    EXPECT_EQ(n, pipeline->mesh().vertices().size() + pipeline->roofCells().size()) << name;
    // every index names a vertex
    const std::size_t idx = g.json["bufferViews"][3]["byteOffset"];
    for (std::size_t k = 0; k < a[3]["count"].get<std::size_t>(); ++k) EXPECT_LT(u32(g.bin, idx + 4 * k), n);
    // the bounds hold every position
    for (std::size_t i = 0; i < n; ++i) {
      for (int c = 0; c < 3; ++c) {
        EXPECT_GE(pos[3 * i + c], a[0]["min"][c].get<float>());
        EXPECT_LE(pos[3 * i + c], a[0]["max"][c].get<float>());
      }
    }
  }
}

}  // namespace
}  // namespace terrain::app
