#pragma once
// Files written from a finished reconstruction: the textured mesh (PLY with vertex colours; OBJ +
// MTL + PNG texture), the labelled voxel map (PCD), height maps before and after recovery
// (colour-mapped PNG with a scale bar), boundary images and per-frame timing.

#include "core/pipeline.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>

namespace terrain::app {

// the colour of what no camera saw (the paper's yellow, Fig. 1c) [RGB]
constexpr std::array<std::uint8_t, 3> kUnseenColour{255, 220, 0};

// A mesh vertex's colour [RGB]: its top voxel's camera colour, or kUnseenColour where no camera saw it.
std::array<std::uint8_t, 3> vertexColour(const Pipeline& pipeline, const MeshVertex& vertex);

// Writes everything into dir (which exists). Files are written whole or not at all.
void writeReconstruction(const std::filesystem::path& dir, const Pipeline& pipeline);

// Writes the boundary images of one camera image (NNNNNN_CAMERA_raw.png, _cleaned.png and, with
// rgb, _overlay.png).
void writeBoundaryImages(const std::filesystem::path& dir, int frame, const std::string& camera,
                         const BoundaryImages& images, const cv::Mat& rgb);

// Colour-mapped height map of a grid of heights (NaN = empty), with a scale bar from lo to hi.
cv::Mat renderHeightMap(const cv::Mat& heights, double lo, double hi, const std::string& title);

}  // namespace terrain::app
