#include "app/outputs.hpp"

#include "app/gltf.hpp"
#include "rig/file_io.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iostream>
#include <sstream>
#include <unordered_map>

namespace terrain::app {

namespace fs = std::filesystem;

namespace {

void writePng(const fs::path& path, const cv::Mat& image) {
  std::vector<uchar> buf;
  if (!cv::imencode(".png", image, buf)) throw io::InputError(path.string() + ": PNG encoding failed");
  io::writeFileAtomic(path, std::string(buf.begin(), buf.end()), true);
}

// The mesh as written: the terrain mesh's vertices, then the roof cells of completed footprints
// (inferred, never sensed or seen), triangulated together on the grid.
struct OutputMesh {
  std::vector<CellIndex> cells;
  std::vector<float> heights;
  std::vector<float> sensed;  // sensed height; NaN for an inferred roof (nothing sensed there)
  std::vector<std::array<std::uint8_t, 3>> colours;
  std::vector<std::uint8_t> unseen, recovered, inferred;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

OutputMesh outputMesh(const Pipeline& p) {
  OutputMesh out;
  std::unordered_map<std::uint64_t, std::uint32_t> index;
  auto key = [](const CellIndex& c) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.x())) << 32) | static_cast<std::uint32_t>(c.y());
  };
  auto add = [&](const CellIndex& c, float h, float sensed, std::array<std::uint8_t, 3> colour, bool unseen,
                 bool recovered, bool inferred) {
    index.emplace(key(c), static_cast<std::uint32_t>(out.cells.size()));
    out.cells.push_back(c);
    out.heights.push_back(h);
    out.sensed.push_back(sensed);
    out.colours.push_back(colour);
    out.unseen.push_back(unseen);
    out.recovered.push_back(recovered);
    out.inferred.push_back(inferred);
  };
  for (const auto& m : p.mesh().vertices()) {
    add(m.cell, m.height(), m.sensed_height, vertexColour(p, m), !p.map().voxels()[m.top_voxel].coloured, m.raised(),
        false);
  }
  for (const auto& r : p.roofCells()) add(r.cell, r.height, std::nanf(""), kUnseenColour, true, true, true);
  out.triangles = gridTriangles(out.cells, [&](const CellIndex& c) -> std::int64_t {
    const auto it = index.find(key(c));
    return it == index.end() ? -1 : static_cast<std::int64_t>(it->second);
  });
  return out;
}

template <typename T>
void append(std::string& s, T v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);
}

void writePly(const fs::path& path, const Pipeline& p, const OutputMesh& mesh) {
  const double cell = p.map().voxelSize();
  std::ostringstream h;
  h << "ply\nformat binary_little_endian 1.0\ncomment terrain reconstruction, world ENU [m]; unseen = never in a "
       "camera image; "
       "inferred = roof of a completed building footprint, not sensed\n"
    << "element vertex " << mesh.cells.size() << "\nproperty float x\nproperty float y\nproperty float z\n"
    << "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar unseen\nproperty uchar "
       "recovered\n"
    << "property uchar inferred\nelement face " << mesh.triangles.size()
    << "\nproperty list uchar int vertex_indices\nend_header\n";
  std::string s = h.str();
  for (std::size_t i = 0; i < mesh.cells.size(); ++i) {
    append(s, static_cast<float>((mesh.cells[i].x() + 0.5) * cell));
    append(s, static_cast<float>((mesh.cells[i].y() + 0.5) * cell));
    append(s, mesh.heights[i]);
    s.append(reinterpret_cast<const char*>(mesh.colours[i].data()), 3);
    append(s, mesh.unseen[i]);
    append(s, mesh.recovered[i]);
    append(s, mesh.inferred[i]);
  }
  for (const auto& t : mesh.triangles) {
    append(s, static_cast<std::uint8_t>(3));
    for (auto i : t) append(s, static_cast<std::int32_t>(i));
  }
  io::writeFileAtomic(path, s, true);
}

// images over the mesh (texture, height maps) are at most this many pixels either way
constexpr std::int64_t kMaxPixels = 4096;

// The grid of the images drawn over the mesh: the cells it spans, and how many cells a pixel
// covers each way (one, unless the mesh spans more than kMaxPixels cells either way).
struct Grid {
  int x0 = 0, y0 = 0;                  // lowest cell
  std::int64_t width = 0, height = 0;  // cells spanned
  int step = 1;                        // cells per pixel each way
  int cols() const { return static_cast<int>((width + step - 1) / step); }
  int rows() const { return static_cast<int>((height + step - 1) / step); }
  int col(const CellIndex& c) const { return static_cast<int>((static_cast<std::int64_t>(c.x()) - x0) / step); }
  int row(const CellIndex& c) const {
    return rows() - 1 - static_cast<int>((static_cast<std::int64_t>(c.y()) - y0) / step);
  }
};

Grid gridOf(const OutputMesh& mesh) {
  Grid g;
  if (mesh.cells.empty()) return g;
  int x0 = mesh.cells[0].x(), x1 = x0, y0 = mesh.cells[0].y(), y1 = y0;
  for (const auto& c : mesh.cells)
    x0 = std::min(x0, c.x()), x1 = std::max(x1, c.x()), y0 = std::min(y0, c.y()), y1 = std::max(y1, c.y());
  g.x0 = x0, g.y0 = y0;
  g.width = static_cast<std::int64_t>(x1) - x0 + 1;
  g.height = static_cast<std::int64_t>(y1) - y0 + 1;
  g.step = static_cast<int>((std::max(g.width, g.height) + kMaxPixels - 1) / kMaxPixels);
  return g;
}

// ", S m per pixel" when a pixel covers more than one cell, for the height maps' titles
std::string scaleNote(const Grid& g, double cell) {
  if (g.step == 1) return "";
  std::ostringstream s;
  s << ", " << g.step * cell << " m per pixel";
  return s.str();
}

void writeObj(const fs::path& dir, const Pipeline& p, const OutputMesh& mesh) {
  const double cell = p.map().voxelSize();
  const Grid g = gridOf(mesh);
  // texture: one texel per cell (per step x step cells on a wide mesh), north up
  cv::Mat tex(std::max(1, g.rows()), std::max(1, g.cols()), CV_8UC3, cv::Scalar(0, 220, 255));
  std::ostringstream obj;
  obj << "# terrain reconstruction, world ENU [m]\nmtllib mesh.mtl\nusemtl terrain\n";
  char line[128];
  for (std::size_t i = 0; i < mesh.cells.size(); ++i) {
    const CellIndex& c = mesh.cells[i];
    std::snprintf(line, sizeof line, "v %.3f %.3f %.3f\n", (c.x() + 0.5) * cell, (c.y() + 0.5) * cell, mesh.heights[i]);
    obj << line;
    const auto& rgb = mesh.colours[i];
    tex.at<cv::Vec3b>(g.row(c), g.col(c)) = cv::Vec3b(rgb[2], rgb[1], rgb[0]);
  }
  for (const auto& c : mesh.cells) {
    std::snprintf(line, sizeof line, "vt %.6f %.6f\n", (c.x() - g.x0 + 0.5) / (static_cast<double>(g.cols()) * g.step),
                  (c.y() - g.y0 + 0.5) / (static_cast<double>(g.rows()) * g.step));
    obj << line;
  }
  for (const auto& t : mesh.triangles)
    obj << "f " << t[0] + 1 << '/' << t[0] + 1 << ' ' << t[1] + 1 << '/' << t[1] + 1 << ' ' << t[2] + 1 << '/'
        << t[2] + 1 << '\n';
  io::writeFileAtomic(dir / "mesh.obj", obj.str(), true);
  io::writeFileAtomic(dir / "mesh.mtl", "newmtl terrain\nKa 1 1 1\nKd 1 1 1\nmap_Kd mesh_texture.png\n", true);
  writePng(dir / "mesh_texture.png", tex);
}

void writeVoxelPcd(const fs::path& path, const Pipeline& p) {
  const auto& voxels = p.map().voxels();
  std::ostringstream h;
  h << "# .PCD v0.7 - labelled voxel map: label 1 ground, 2 non-ground, 0 unknown; rough 1 = in G1\nVERSION 0.7\n"
    << "FIELDS x y z rgb hits label rough\nSIZE 4 4 4 4 4 1 1\nTYPE F F F U U U U\nCOUNT 1 1 1 1 1 1 1\nWIDTH "
    << voxels.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << voxels.size() << "\nDATA binary\n";
  std::string s = h.str();
  const auto& rough = p.segmentation().rough;
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    const Voxel& v = voxels[i];
    append(s, static_cast<float>((v.index.x() + 0.5) * p.map().voxelSize()));
    append(s, static_cast<float>((v.index.y() + 0.5) * p.map().voxelSize()));
    append(s, v.height);
    const std::uint32_t rgb = v.coloured ? (std::uint32_t{v.r} << 16 | std::uint32_t{v.g} << 8 | v.b) : 0xffdc00u;
    append(s, rgb);
    append(s, v.hits);
    append(s, static_cast<std::uint8_t>(v.label));
    append(s, static_cast<std::uint8_t>(i < rough.size() ? rough[i] : 0));
  }
  io::writeFileAtomic(path, s, true);
}

void writeTiming(const fs::path& dir, const Pipeline& p) {
  std::ostringstream csv;
  csv << "frame,points,new_voxels,voxels,pose_ms,voxel_ms,mesh_ms,segmentation_ms,boundary_ms,estimation_ms,total_ms,"
         "estimated_vertices,resident_mb\n";
  for (const auto& r : p.records()) {
    csv << r.frame << ',' << r.points << ',' << r.new_voxels << ',' << r.voxels << ',' << r.pose_ms << ',' << r.voxel_ms
        << ',' << r.mesh_ms << ',' << r.segmentation_ms << ',' << r.boundary_ms << ',' << r.estimation_ms << ','
        << r.total_ms << ',' << r.estimated_vertices << ',' << r.resident_bytes / 1e6 << '\n';
  }
  io::writeFileAtomic(dir / "timing.csv", csv.str(), true);
}

}  // namespace

cv::Mat renderHeightMap(const cv::Mat& heights, double lo, double hi, const std::string& title) {
  const int scale = std::max(1, 800 / std::max(1, std::max(heights.cols, heights.rows)));
  cv::Mat grey(heights.rows, heights.cols, CV_8UC1), mask(heights.rows, heights.cols, CV_8UC1);
  for (int r = 0; r < heights.rows; ++r) {
    for (int c = 0; c < heights.cols; ++c) {
      const float h = heights.at<float>(r, c);
      mask.at<std::uint8_t>(r, c) = std::isfinite(h) ? 255 : 0;
      grey.at<std::uint8_t>(r, c) =
          static_cast<std::uint8_t>(std::clamp((h - lo) / std::max(1e-6, hi - lo), 0.0, 1.0) * 255.0);
    }
  }
  cv::Mat coloured;
  cv::applyColorMap(grey, coloured, cv::COLORMAP_JET);
  coloured.setTo(cv::Scalar(255, 255, 255), mask == 0);
  cv::resize(coloured, coloured, cv::Size(), scale, scale, cv::INTER_NEAREST);
  // canvas with a title and a scale bar on the right
  const int bar_w = 30, margin = 90, top = 40;
  cv::Mat canvas(coloured.rows + top + 20, coloured.cols + margin + bar_w, CV_8UC3, cv::Scalar(255, 255, 255));
  coloured.copyTo(canvas(cv::Rect(10, top, coloured.cols, coloured.rows)));
  cv::putText(canvas, title, cv::Point(10, 28), cv::FONT_HERSHEY_SIMPLEX, 0.7, cv::Scalar(0, 0, 0), 2);
  const int bx = coloured.cols + 30, bh = coloured.rows;
  for (int y = 0; y < bh; ++y) {
    cv::Mat px(1, 1, CV_8UC1, cv::Scalar(255 - y * 255 / std::max(1, bh - 1)));
    cv::Mat c;
    cv::applyColorMap(px, c, cv::COLORMAP_JET);
    cv::line(canvas, {bx, top + y}, {bx + bar_w, top + y}, cv::Scalar(c.at<cv::Vec3b>(0, 0)), 1);
  }
  for (int k = 0; k <= 4; ++k) {
    const int y = top + (bh - 1) * k / 4;
    char label[32];
    std::snprintf(label, sizeof label, "%.1f m", hi - (hi - lo) * k / 4.0);
    cv::putText(canvas, label, cv::Point(bx + bar_w + 4, y + 5), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0),
                1);
  }
  return canvas;
}

void writeBoundaryImages(const fs::path& dir, int frame, const std::string& camera, const BoundaryImages& images,
                         const cv::Mat& rgb) {
  char number[64];
  std::snprintf(number, sizeof number, "%06d_", frame);
  const std::string name = number + camera;
  // black boundary on white, as in the paper's Figure 7
  writePng(dir / (std::string(name) + "_raw.png"), 255 - images.raw);
  writePng(dir / (std::string(name) + "_cleaned.png"), 255 - images.cleaned);
  if (!rgb.empty()) {
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    bgr.setTo(cv::Scalar(0, 0, 255), images.cleaned);
    writePng(dir / (std::string(name) + "_overlay.png"), bgr);
  }
}

// mesh.glb (after recovery) and mesh_before.glb (the sensed heights; the inferred roofs left out)
void writeGlbs(const fs::path& dir, const Pipeline& p, const OutputMesh& mesh) {
  const double cell = p.map().voxelSize();
  for (const bool before : {false, true}) {
    GlbMesh g;
    g.name = before ? "terrain, sensed only" : "terrain after recovery";
    for (std::size_t i = 0; i < mesh.cells.size(); ++i) {
      const float h = before ? mesh.sensed[i] : mesh.heights[i];
      g.positions.emplace_back((mesh.cells[i].x() + 0.5) * cell, (mesh.cells[i].y() + 0.5) * cell,
                               std::isnan(h) ? 0.0 : h);
      g.colours.push_back(mesh.colours[i]);
    }
    for (const auto& t : mesh.triangles) {
      if (before && (std::isnan(mesh.sensed[t[0]]) || std::isnan(mesh.sensed[t[1]]) || std::isnan(mesh.sensed[t[2]])))
        continue;
      g.triangles.push_back(t);
    }
    io::writeFileAtomic(dir / (before ? "mesh_before.glb" : "mesh.glb"), encodeGlb(g), true);
  }
}

std::array<std::uint8_t, 3> vertexColour(const Pipeline& p, const MeshVertex& m) {
  const Voxel& v = p.map().voxels()[m.top_voxel];
  if (v.coloured) return {v.r, v.g, v.b};
  return kUnseenColour;
}

void writeReconstruction(const fs::path& dir, const Pipeline& p) {
  const OutputMesh mesh = outputMesh(p);
  writePly(dir / "mesh.ply", p, mesh);
  writeObj(dir, p, mesh);
  writeGlbs(dir, p, mesh);
  writeVoxelPcd(dir / "voxels.pcd", p);
  writeTiming(dir, p);
  // height maps before and after recovery, on one colour scale; the roofs of completed footprints
  // only after
  const Grid g = gridOf(mesh);
  nlohmann::json w = p.warnings();
  if (g.width > 0) {
    const double cell = p.map().voxelSize();
    if (g.step > 1) {
      std::ostringstream m;
      m << "the mesh spans " << g.width * cell << " x " << g.height * cell
        << " m: its texture and height maps are drawn at " << g.step * cell
        << " m per pixel (in the height maps each pixel shows its highest cell)";
      w.push_back(m.str());
      std::cerr << "warning: " << m.str() << "\n";
    }
    // the highest cell of each pixel
    const auto raise = [](float& px, float h) { px = std::isnan(px) ? h : std::max(px, h); };
    cv::Mat before(g.rows(), g.cols(), CV_32FC1, cv::Scalar(std::nanf(""))), after = before.clone();
    double lo = 1e9, hi = -1e9;
    for (const auto& m : p.mesh().vertices()) {
      raise(before.at<float>(g.row(m.cell), g.col(m.cell)), m.sensed_height);
      raise(after.at<float>(g.row(m.cell), g.col(m.cell)), m.height());
      lo = std::min(lo, static_cast<double>(m.sensed_height));
      hi = std::max(hi, static_cast<double>(m.height()));
    }
    for (const auto& r : p.roofCells()) {
      raise(after.at<float>(g.row(r.cell), g.col(r.cell)), r.height);
      hi = std::max(hi, static_cast<double>(r.height));
    }
    writePng(dir / "height_before.png",
             renderHeightMap(before, lo, hi, "height, sensed only (north up" + scaleNote(g, cell) + ")"));
    writePng(dir / "height_after.png",
             renderHeightMap(after, lo, hi,
                             "height after 3D boundary estimation and footprint completion" + scaleNote(g, cell)));
  }
  io::writeFileAtomic(dir / "warnings.json", w.dump(1) + "\n", true);
}

}  // namespace terrain::app
