#include "rig/kitti.hpp"

#include "rig/file_io.hpp"

#include <cmath>
#include <cstring>

namespace terrain::rig {

KittiScan readKittiScan(const std::filesystem::path& path) {
  const std::string bytes = io::readFile(path);
  if (bytes.size() % 16 != 0) {
    throw io::InputError(path.string() + ": " + std::to_string(bytes.size()) +
                         " bytes is not a whole number of 16-byte points (x, y, z, reflectance as float32)");
  }
  KittiScan s;
  const std::size_t n = bytes.size() / 16;
  s.points.reserve(n);
  s.reflectance.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    float v[4];
    std::memcpy(v, bytes.data() + 16 * i, 16);
    s.points.emplace_back(v[0], v[1], v[2]);
    s.reflectance.push_back(v[3]);
  }
  return s;
}

std::vector<std::uint16_t> readSemanticKittiLabels(const std::filesystem::path& path, std::size_t points) {
  const std::string bytes = io::readFile(path);
  if (bytes.size() != 4 * points) {
    throw io::InputError(path.string() + ": holds " + std::to_string(bytes.size() / 4) + " labels for " +
                         std::to_string(points) + " points");
  }
  std::vector<std::uint16_t> labels(points);
  for (std::size_t i = 0; i < points; ++i) {
    std::uint32_t v;
    std::memcpy(&v, bytes.data() + 4 * i, 4);
    labels[i] = static_cast<std::uint16_t>(v & 0xffff);
  }
  return labels;
}

}  // namespace terrain::rig
