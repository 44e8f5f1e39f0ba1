#include "app/gltf.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstring>
#include <limits>

namespace terrain::app {

namespace {

constexpr std::uint32_t kMagic = 0x46546C67;      // "glTF"
constexpr std::uint32_t kJsonChunk = 0x4E4F534A;  // "JSON"
constexpr std::uint32_t kBinChunk = 0x004E4942;   // "BIN\0"
constexpr int kFloat = 5126, kUnsignedByte = 5121, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

template <typename T>
void put(std::string& s, T v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);
}

// world ENU to glTF's y-up frame
Eigen::Vector3f toGltf(const Vector3& p) {
  return {static_cast<float>(p.x()), static_cast<float>(p.z()), static_cast<float>(-p.y())};
}

}  // namespace

std::string encodeGlb(const GlbMesh& mesh) {
  const std::size_t n = mesh.positions.size();
  std::vector<Eigen::Vector3f> pos(n), normal(n, Eigen::Vector3f::Zero());
  for (std::size_t i = 0; i < n; ++i) pos[i] = toGltf(mesh.positions[i]);
  for (const auto& t : mesh.triangles) {
    Eigen::Vector3f f = (pos[t[1]] - pos[t[0]]).cross(pos[t[2]] - pos[t[0]]);  // twice the area
    if (f.y() < 0) f = -f;
    for (auto i : t) normal[i] += f;
  }
  for (auto& v : normal) v = v.norm() > 0 ? Eigen::Vector3f(v.normalized()) : Eigen::Vector3f::UnitY();

  // the binary chunk: positions, normals, colours, indices, each 4-byte aligned
  std::string bin;
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
  for (const auto& p : pos) {
    for (int k = 0; k < 3; ++k) put(bin, p[k]);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const std::size_t normals_at = bin.size();
  for (const auto& v : normal) {
    for (int k = 0; k < 3; ++k) put(bin, v[k]);
  }
  const std::size_t colours_at = bin.size();
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = i < mesh.colours.size() ? mesh.colours[i] : std::array<std::uint8_t, 3>{200, 200, 200};
    bin.append(reinterpret_cast<const char*>(c.data()), 3);
    bin.push_back(static_cast<char>(255));
  }
  const std::size_t indices_at = bin.size();
  for (const auto& t : mesh.triangles) {
    for (auto i : t) put(bin, i);
  }
  const std::size_t indices_bytes = bin.size() - indices_at;
  while (bin.size() % 4 != 0) bin.push_back('\0');

  using nlohmann::json;
  json j;
  j["asset"] = {{"version", "2.0"},
                {"generator", "terrain (robot terrain reconstruction testbed)"},
                {"extras", {{"frame", "glTF y up: (x, y, z) = world ENU (x east, z up, -y north) [m]"}}}};
  j["scene"] = 0;
  j["scenes"] = json::array({{{"nodes", {0}}}});
  j["nodes"] = json::array({{{"mesh", 0}, {"name", mesh.name}}});
  j["materials"] =
      json::array({{{"name", "vertex colours"},
                    {"doubleSided", true},
                    {"pbrMetallicRoughness",
                     {{"baseColorFactor", {1, 1, 1, 1}}, {"metallicFactor", 0.0}, {"roughnessFactor", 1.0}}}}});
  json primitive = {{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"COLOR_0", 2}}}, {"mode", 4}, {"material", 0}};
  if (!mesh.triangles.empty()) primitive["indices"] = 3;
  j["meshes"] = json::array({{{"name", mesh.name}, {"primitives", {primitive}}}});
  j["buffers"] = json::array({{{"byteLength", bin.size()}}});
  json views =
      json::array({{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 12 * n}, {"target", kArrayBuffer}},
                   {{"buffer", 0}, {"byteOffset", normals_at}, {"byteLength", 12 * n}, {"target", kArrayBuffer}},
                   {{"buffer", 0}, {"byteOffset", colours_at}, {"byteLength", 4 * n}, {"target", kArrayBuffer}}});
  json accessors = json::array(
      {{{"bufferView", 0},
        {"componentType", kFloat},
        {"count", n},
        {"type", "VEC3"},
        {"min", n ? json{lo.x(), lo.y(), lo.z()} : json{0, 0, 0}},
        {"max", n ? json{hi.x(), hi.y(), hi.z()} : json{0, 0, 0}}},
       {{"bufferView", 1}, {"componentType", kFloat}, {"count", n}, {"type", "VEC3"}},
       {{"bufferView", 2}, {"componentType", kUnsignedByte}, {"normalized", true}, {"count", n}, {"type", "VEC4"}}});
  if (!mesh.triangles.empty()) {
    views.push_back(
        {{"buffer", 0}, {"byteOffset", indices_at}, {"byteLength", indices_bytes}, {"target", kElementArrayBuffer}});
    accessors.push_back(
        {{"bufferView", 3}, {"componentType", kUnsignedInt}, {"count", 3 * mesh.triangles.size()}, {"type", "SCALAR"}});
  }
  j["bufferViews"] = views;
  j["accessors"] = accessors;
  std::string text = j.dump();
  while (text.size() % 4 != 0) text.push_back(' ');

  std::string out;
  put(out, kMagic);
  put(out, std::uint32_t{2});
  put(out, static_cast<std::uint32_t>(12 + 8 + text.size() + 8 + bin.size()));
  put(out, static_cast<std::uint32_t>(text.size()));
  put(out, kJsonChunk);
  out += text;
  put(out, static_cast<std::uint32_t>(bin.size()));
  put(out, kBinChunk);
  out += bin;
  return out;
}

}  // namespace terrain::app
