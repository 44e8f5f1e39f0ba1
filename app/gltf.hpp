#pragma once
// Binary glTF 2.0 (.glb) of a coloured triangle mesh, as Blender, three.js and glTF validators
// read it: one node, one mesh, one primitive with POSITION, NORMAL, COLOR_0 (RGBA bytes,
// normalised) and 32-bit indices; a double-sided, non-metallic material that shows the colours.
//
// Frame: glTF is y up; the world is ENU, z up. A world point (x east, y north, z up) [m] is the
// glTF point (x, z, -y): a rotation of -90 degrees about x, right-handed, metres kept.

#include "core/types.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace terrain::app {

struct GlbMesh {
  std::vector<Vector3> positions;                    // world ENU [m]
  std::vector<std::array<std::uint8_t, 3>> colours;  // per vertex, sRGB
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::string name = "terrain";
};

// The .glb bytes. Vertex normals are the area-weighted normals of the triangles around each
// vertex, turned upwards (a terrain seen from above); a vertex no triangle uses gets the up axis.
std::string encodeGlb(const GlbMesh& mesh);

}  // namespace terrain::app
