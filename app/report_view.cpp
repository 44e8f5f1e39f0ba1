#include "app/report_view.hpp"

#include "app/html_report.hpp"
#include "app/outputs.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

namespace terrain::app {

// generated at build time from web/src/viewer.js (app/CMakeLists.txt, cmake/EmbedView.cmake)
extern const char* const kViewBundle;
extern const char* const kViewMissing;

namespace {

std::uint64_t key(std::int64_t x, std::int64_t y) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(x)) << 32) | static_cast<std::uint32_t>(y);
}

// floor division (cells may be negative)
std::int64_t binOf(std::int64_t c, int step) { return c >= 0 ? c / step : -((-c + step - 1) / step); }

// heights as uint16 little-endian: 0 = none, else 1 + round((h - lo) / step)
std::vector<unsigned char> quantise(const std::vector<float>& h, double lo, double step) {
  std::vector<unsigned char> out(2 * h.size(), 0);
  for (std::size_t i = 0; i < h.size(); ++i) {
    if (!std::isfinite(h[i])) continue;
    const long q = 1 + std::lround((h[i] - lo) / step);
    const auto v = static_cast<std::uint16_t>(std::clamp(q, 1L, 65535L));
    out[2 * i] = static_cast<unsigned char>(v & 0xff);
    out[2 * i + 1] = static_cast<unsigned char>(v >> 8);
  }
  return out;
}

// what would end or escape a script element inside one ("</script", "<!--"), with a backslash that
// JavaScript strings and regular expressions read as nothing
std::string scriptSafe(std::string s) {
  for (const char* bad : {"</script", "</SCRIPT", "<!--"}) {
    for (std::size_t at = s.find(bad); at != std::string::npos; at = s.find(bad, at + 3)) s.insert(at + 1, "\\");
  }
  return s;
}

}  // namespace

std::string reportView(const Pipeline& p, const eval::RunTruth& truth, const sim::World& world, ViewGrid* grid) {
  std::ostringstream h;
  h << "<h2>3D view</h2>";
  if (kViewBundle[0] == '\0') {
    h << "<p id=\"terrain-view-status\"><b>No 3D view:</b> " << kViewMissing
      << ". The rest of the report is complete.</p>";
    return h.str();
  }
  const auto& vertices = p.mesh().vertices();
  const double voxel = p.map().voxelSize();
  // the cells: mesh vertices (sensed and recovered heights, colours) and roof cells (recovered only)
  struct Cell {
    std::int64_t x, y;
    float before, after;
    std::array<std::uint8_t, 3> colour;
  };
  std::vector<Cell> cells;
  cells.reserve(vertices.size() + p.roofCells().size());
  for (const auto& m : vertices)
    cells.push_back({m.cell.x(), m.cell.y(), m.sensed_height, m.height(), vertexColour(p, m)});
  for (const auto& r : p.roofCells()) {
    cells.push_back({r.cell.x(), r.cell.y(), std::numeric_limits<float>::quiet_NaN(), r.height, kUnseenColour});
  }
  if (cells.empty()) {
    h << "<p id=\"terrain-view-status\">No 3D view: the map is empty.</p>";
    return h.str();
  }
  // the finest grid (a whole number of cells a step) whose occupied points fit the budget
  int step = 1;
  for (;; ++step) {
    std::unordered_set<std::uint64_t> occupied;
    for (const Cell& c : cells) {
      occupied.insert(key(binOf(c.x, step), binOf(c.y, step)));
      if (occupied.size() > kViewVertexBudget) break;
    }
    if (occupied.size() <= kViewVertexBudget) break;
  }
  std::int64_t x0 = std::numeric_limits<std::int64_t>::max(), y0 = x0, x1 = std::numeric_limits<std::int64_t>::min(),
               y1 = x1;
  for (const Cell& c : cells) {
    x0 = std::min(x0, binOf(c.x, step)), x1 = std::max(x1, binOf(c.x, step));
    y0 = std::min(y0, binOf(c.y, step)), y1 = std::max(y1, binOf(c.y, step));
  }
  const std::int64_t cols = x1 - x0 + 1, rows = y1 - y0 + 1;
  const double cell = step * voxel;
  // each grid point: the highest cell binned into it (its heights and colour), so that tops survive
  const auto nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> before(static_cast<std::size_t>(cols * rows), nan), after = before, truth_h = before;
  std::vector<unsigned char> rgb(3 * before.size(), 0);
  for (const Cell& c : cells) {
    const std::size_t i = static_cast<std::size_t>((binOf(c.y, step) - y0) * cols + (binOf(c.x, step) - x0));
    if (std::isfinite(after[i]) && after[i] >= c.after) continue;
    after[i] = c.after;
    before[i] = c.before;
    std::copy(c.colour.begin(), c.colour.end(), rgb.begin() + static_cast<std::ptrdiff_t>(3 * i));
  }
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  std::size_t count = 0;
  for (std::size_t i = 0; i < after.size(); ++i) {
    if (!std::isfinite(after[i])) continue;
    ++count;
    const double gx = (static_cast<double>(x0 + static_cast<std::int64_t>(i % cols)) + 0.5) * cell;
    const double gy = (static_cast<double>(y0 + static_cast<std::int64_t>(i / cols)) + 0.5) * cell;
    truth_h[i] = static_cast<float>(world.surfaceHeight(gx, gy));
    for (float v : {before[i], after[i], truth_h[i]}) {
      if (std::isfinite(v)) lo = std::min(lo, static_cast<double>(v)), hi = std::max(hi, static_cast<double>(v));
    }
  }
  const double q = std::max(1e-6, (hi - lo) / 65534.0);
  // the estimated path (at most 2000 points) and the cameras of the report's frames
  nlohmann::json path = nlohmann::json::array(), cameras = nlohmann::json::array();
  const auto& records = p.records();
  const std::size_t every = std::max<std::size_t>(1, records.size() / 2000);
  for (std::size_t i = 0; i < records.size(); i += every) {
    const Point3& x = records[i].position;
    path.push_back({x.x(), x.y(), x.z()});
  }
  for (const auto& c : truth.cameras) {
    const Point3 o = c.world_from_camera.translation();
    const Vector3 axis = c.world_from_camera.linear().col(2);
    cameras.push_back({o.x(), o.y(), o.z(), axis.x(), axis.y(), axis.z()});
  }
  const nlohmann::json data = {{"cols", cols},
                               {"rows", rows},
                               {"cell", cell},
                               {"x0", static_cast<double>(x0) * cell},
                               {"y0", static_cast<double>(y0) * cell},
                               {"lo", lo},
                               {"hi", hi},
                               {"step", q},
                               {"vertices", count},
                               {"before", base64(quantise(before, lo, q))},
                               {"after", base64(quantise(after, lo, q))},
                               {"truth", base64(quantise(truth_h, lo, q))},
                               {"colours", base64(rgb)},
                               {"path", path},
                               {"cameras", cameras}};
  if (grid) *grid = {cell, step, count, cells.size()};
  h << "<p>The reconstruction in 3D (world ENU, z up): <span id=\"terrain-view-count\">" << count
    << "</span> vertices, ";
  if (step > 1) {
    h << "decimated from " << cells.size() << " mesh vertices and roof cells: binned to a grid of " << cell << " m ("
      << step << " &times; " << step << " cells, the highest of each), since the view embeds at most "
      << kViewVertexBudget << " points";
  } else {
    h << "every mesh vertex and roof cell (the view embeds at most " << kViewVertexBudget
      << " points; more are binned)";
  }
  h << "; heights to " << std::ceil(q * 1000.0)
    << " mm. Yellow: never in a camera image. Red line: the robot's estimated path; orange dots: the cameras at the "
       "report's frames.</p>"
       "<form id=\"terrain-view-controls\" style=\"margin:6px 0\">"
       "<label><input type=\"radio\" name=\"layer\" value=\"after\" checked> after recovery</label> "
       "<label><input type=\"radio\" name=\"layer\" value=\"before\"> sensed only</label> "
       "<label><input type=\"radio\" name=\"layer\" value=\"truth\"> ground truth (colour = height)</label> "
       "<label><input type=\"radio\" name=\"layer\" value=\"error\"> error after recovery (blue &minus;10 m, red +10 "
       "m)</label>"
       " &nbsp; <label><input type=\"checkbox\" name=\"truth\"> truth as a transparent layer</label> "
       "<label><input type=\"checkbox\" name=\"path\" checked> path</label> "
       "<label><input type=\"checkbox\" name=\"cameras\" checked> cameras</label></form>"
       "<div id=\"terrain-view\" style=\"width:100%;max-width:1200px;height:600px;border:1px solid #bbb\"></div>"
       "<p id=\"terrain-view-status\">The 3D view needs JavaScript and WebGL.</p>"
       "<script id=\"terrain-view-data\" type=\"application/json\">"
    << scriptSafe(data.dump()) << "</script><script>" << scriptSafe(kViewBundle) << "</script>";
  return h.str();
}

}  // namespace terrain::app
