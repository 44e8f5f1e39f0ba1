#include "app/html_report.hpp"

#include "app/outputs.hpp"
#include "app/report_view.hpp"
#include "core/camera_model.hpp"
#include "evaluation/metrics.hpp"
#include "evaluation/report.hpp"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <sstream>

namespace terrain::app {

std::string base64(const std::vector<unsigned char>& data) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((data.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < data.size(); i += 3) {
    const std::uint32_t n = (std::uint32_t{data[i]} << 16) |
                            (i + 1 < data.size() ? std::uint32_t{data[i + 1]} << 8 : 0) |
                            (i + 2 < data.size() ? data[i + 2] : 0);
    out += table[(n >> 18) & 63];
    out += table[(n >> 12) & 63];
    out += i + 1 < data.size() ? table[(n >> 6) & 63] : '=';
    out += i + 2 < data.size() ? table[n & 63] : '=';
  }
  return out;
}

namespace {

std::string img(const cv::Mat& bgr, const std::string& alt) {
  std::vector<uchar> png;
  cv::imencode(".png", bgr, png);
  return "<img alt=\"" + alt + "\" src=\"data:image/png;base64," + base64(png) + "\">";
}

// a simple chart: axes, series as polylines, one horizontal reference line
cv::Mat lineChart(const std::vector<std::pair<std::string, std::vector<double>>>& series, double reference,
                  const std::string& title, const std::string& unit) {
  const int w = 760, h = 320, l = 60, b = 40, t = 30;
  cv::Mat c(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double ymax = reference * 1.2;
  std::size_t n = 1;
  for (const auto& [name, v] : series) {
    for (double x : v) ymax = std::max(ymax, x * 1.1);
    n = std::max(n, v.size());
  }
  if (!(ymax > 0)) ymax = 1;  // nothing above zero to show
  cv::line(c, {l, h - b}, {w - 10, h - b}, cv::Scalar(0, 0, 0));
  cv::line(c, {l, t}, {l, h - b}, cv::Scalar(0, 0, 0));
  auto py = [&](double y) { return static_cast<int>(h - b - (h - b - t) * y / ymax); };
  auto px = [&](std::size_t i) {
    return static_cast<int>(l + (w - 10 - l) * static_cast<double>(i) / std::max<std::size_t>(1, n - 1));
  };
  cv::line(c, {l, py(reference)}, {w - 10, py(reference)}, cv::Scalar(0, 0, 200), 1, cv::LINE_AA);
  cv::putText(c, title, {l, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  for (int k = 0; k <= 4; ++k) {
    char lab[32];
    std::snprintf(lab, sizeof lab, "%.0f %s", ymax * k / 4, unit.c_str());
    cv::putText(c, lab, {2, py(ymax * k / 4) + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.35, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  const cv::Scalar colours[] = {{200, 80, 0}, {0, 150, 0}, {150, 0, 150}, {0, 120, 220}};
  int s = 0;
  for (const auto& [name, v] : series) {
    for (std::size_t i = 1; i < v.size(); ++i)
      cv::line(c, {px(i - 1), py(v[i - 1])}, {px(i), py(v[i])}, colours[s % 4], 2, cv::LINE_AA);
    cv::putText(c, name, {w - 240, t + 16 * (s + 1)}, cv::FONT_HERSHEY_SIMPLEX, 0.45, colours[s % 4], 1, cv::LINE_AA);
    ++s;
  }
  cv::putText(c, "frame", {w / 2, h - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  return c;
}

cv::Mat histogram(const std::vector<double>& before, const std::vector<double>& after, double lo, double hi, int bins) {
  const int w = 760, h = 300, l = 40, b = 40;
  cv::Mat c(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  std::vector<int> hb(bins, 0), ha(bins, 0);
  auto fill = [&](const std::vector<double>& e, std::vector<int>& hist) {
    for (double x : e) hist[std::clamp(static_cast<int>((x - lo) / (hi - lo) * bins), 0, bins - 1)]++;
  };
  fill(before, hb);
  fill(after, ha);
  const int top =
      std::max(1, std::max(*std::max_element(hb.begin(), hb.end()), *std::max_element(ha.begin(), ha.end())));
  const double bw = (w - l - 10.0) / bins;
  for (int i = 0; i < bins; ++i) {
    const int x = l + static_cast<int>(i * bw);
    cv::rectangle(c, {x, h - b - (h - b - 30) * hb[i] / top}, {x + static_cast<int>(bw / 2), h - b},
                  cv::Scalar(180, 180, 180), cv::FILLED);
    cv::rectangle(c, {x + static_cast<int>(bw / 2), h - b - (h - b - 30) * ha[i] / top},
                  {x + static_cast<int>(bw), h - b}, cv::Scalar(200, 80, 0), cv::FILLED);
  }
  for (int k = 0; k <= 5; ++k) {
    char lab[32];
    std::snprintf(lab, sizeof lab, "%.0f m", lo + (hi - lo) * k / 5);
    cv::putText(c, lab, {l + static_cast<int>((w - l - 10) * k / 5.0) - 10, h - 20}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  cv::putText(c, "height error of object vertices: grey sensed only, blue after recovery", {l, 20},
              cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  return c;
}

std::string fmt(const nlohmann::json& j) {
  if (!j.is_number()) return "-";
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", j.get<double>());
  return b;
}

}  // namespace

std::string htmlReport(const nlohmann::json& r, const Pipeline& p, const eval::RunTruth& truth, const sim::World& world,
                       const std::string& title) {
  std::ostringstream h;
  h << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" << title
    << "</title><style>body{font-family:sans-serif;max-width:1600px;margin:20px}table{border-collapse:collapse}"
       "td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}th{background:#eee}img{margin:4px;max-width:100%}"
       "</style></head><body><h1>"
    << title << "</h1><p>" << r.value("frames", 0) << " frames, " << r.value("voxels", 0)
    << " voxels. Scene: " << world.truth().type << " (seed " << world.truth().seed << ").</p>"
    << reportView(p, truth, world);
  // metrics
  if (r.contains("pose") && r["pose"].value("frames", 0) > 0) {
    const auto& pose = r["pose"];
    h << "<h2>Pose</h2><p>At the " << pose["frames"].get<int>() << " kept camera frames, the final pose against the "
      << "true one.</p><table><tr><th>error</th><th>median</th><th>max</th></tr>";
    for (const char* k :
         {"horizontal_error_m", "vertical_error_m", "heading_error_deg", "pitch_error_deg", "roll_error_deg"})
      h << "<tr><td style=\"text-align:left\">" << k << "</td><td>" << fmt(pose[k]["median"]) << "</td><td>"
        << fmt(pose[k]["max"]) << "</td></tr>";
    h << "</table>";
  }
  h << "<h2>Ground segmentation</h2><table><tr><th>method</th><th>F1</th><th>IoU</th><th>precision</th><th>recall</th>"
       "<th>F1 per point</th></tr>";
  for (const char* m : eval::kGroundMethods) {
    if (!r["ground_segmentation"].contains(m)) continue;  // baselines not asked for
    const auto& g = r["ground_segmentation"][m];
    h << "<tr><td style=\"text-align:left\">" << m << "</td><td>" << fmt(g["f1"]) << "</td><td>" << fmt(g["iou"])
      << "</td><td>" << fmt(g["precision"]) << "</td><td>" << fmt(g["recall"]) << "</td><td>"
      << fmt(g["per_point"]["f1"]) << "</td></tr>";
  }
  h << "</table><h2>Object heights</h2><table><tr><th></th><th>cells</th><th>MAE m</th><th>RMSE m</th><th>bias m</th>"
       "<th>variance m&sup2;</th></tr>";
  const auto& hr = r["height_recovery"];
  auto row = [&](const std::string& name, const nlohmann::json& e) {
    h << "<tr><td style=\"text-align:left\">" << name << "</td><td>" << e.value("cells", 0) << "</td><td>"
      << fmt(e["mae_m"]) << "</td><td>" << fmt(e["rmse_m"]) << "</td><td>" << fmt(e["bias_m"]) << "</td><td>"
      << fmt(e["variance_m2"]) << "</td></tr>";
  };
  row("sensed only", hr["before"]);
  row("after boundary estimation", hr["after"]);
  row("estimated cells, sensed only", hr["estimated_cells"]["before"]);
  row("estimated cells, after", hr["estimated_cells"]["after"]);
  if (hr.contains("footprints")) {
    row("roofs of " + std::to_string(hr["footprints"]["completed"].get<std::size_t>()) + " completed footprints (" +
            std::to_string(hr["footprints"]["wrongly_filled_cells"].get<std::size_t>()) + " more cells over terrain)",
        hr["footprints"]["on_objects"]);
  }
  if (hr.contains("by_camera_view")) {
    for (auto it = hr["by_camera_view"].begin(); it != hr["by_camera_view"].end(); ++it) {
      std::string name = it.key();
      std::replace(name.begin(), name.end(), '_', ' ');
      row(name + ", sensed only", it.value()["before"]);
      row(name + ", after (" + std::to_string(it.value()["raised_cells"].get<std::size_t>()) + " raised)",
          it.value()["after"]);
    }
  }
  if (hr.contains("by_distance")) {
    for (auto it = hr["by_distance"].begin(); it != hr["by_distance"].end(); ++it) {
      row(it.key() + " m, sensed only", it.value()["before"]);
      row(it.key() + " m, after", it.value()["after"]);
    }
  }
  // the three largest non-zero counts of an outcome map, largest first ("name n, ...")
  const auto largest = [](const nlohmann::json& counts) {
    std::vector<std::pair<std::uint64_t, std::string>> v;
    for (auto c = counts.begin(); c != counts.end(); ++c) {
      if (c.value().get<std::uint64_t>() > 0) v.emplace_back(c.value().get<std::uint64_t>(), c.key());
    }
    std::stable_sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::string out;
    for (std::size_t i = 0; i < std::min<std::size_t>(3, v.size()); ++i)
      out += (i ? ", " : "") + v[i].second + " " + std::to_string(v[i].first);
    return out.empty() ? std::string("none") : out;
  };
  if (hr.contains("object_tops")) {
    // each object whose top the camera saw: its true, sensed and recovered top
    const auto& tops = hr["object_tops"];
    h << "</table><h3>Object tops the camera saw</h3><p>";
    for (const char* kind : {"building", "tree"}) {
      const auto& t = tops[kind];
      h << kind << "s at their real height (within 10 % of their height, at least 1 m): "
        << t["at_height_before"].get<std::size_t>() << " sensed only, " << t["at_height_after"].get<std::size_t>()
        << " after recovery, of " << t["top_seen"].get<std::size_t>()
        << "; above it by more than that: " << t["too_high_before"].get<std::size_t>() << " sensed only, "
        << t["too_high_after"].get<std::size_t>() << " after recovery. ";
    }
    h << "Of those, seen in a frame that also saw their lower part (within " << eval::kLowerPart
      << " m of the base, where the lidar reaches; the method raises an object only from such a frame):";
    for (const char* kind : {"building", "tree"}) {
      const auto& w = tops[kind]["lower_part_seen_with_top"];
      h << " " << kind << "s " << w["at_height_before"].get<std::size_t>() << " sensed only, "
        << w["at_height_after"].get<std::size_t>() << " after recovery, of " << w["objects"].get<std::size_t>() << ";";
    }
    h << "</p><table><tr><th>object</th><th>class</th><th>true top m</th><th>sensed top m</th><th>recovered top m</th>"
         "<th>error m</th><th>frames (with lower part)</th><th>cells</th><th>estimation (vertex-frames)</th>"
         "<th>crown (frames: verdict)</th></tr>";
    for (auto it = tops["list"].begin(); it != tops["list"].end(); ++it) {
      const auto& o = it.value();
      const bool ok = std::abs(o["error_m"].get<double>()) <= o["tolerance_m"].get<double>();
      h << "<tr><td style=\"text-align:left\">" << it.key() << "</td><td>" << o["class"].get<std::string>()
        << "</td><td>" << fmt(o["true_top_m"]) << "</td><td>" << fmt(o["sensed_top_m"]) << "</td><td>"
        << fmt(o["recovered_top_m"]) << "</td><td" << (ok ? "" : " style=\"color:#b00\"") << ">" << fmt(o["error_m"])
        << "</td><td>" << o["frames_top_seen"].get<int>() << " (" << o["frames_lower_part_seen_with_top"].get<int>()
        << ")</td><td>" << o["cells"].get<std::size_t>() << "</td><td style=\"text-align:left\">"
        << (o.contains("estimation_outcomes") ? largest(o["estimation_outcomes"]) : "")
        << "</td><td style=\"text-align:left\">";
      if (o.contains("crown") && o["crown"].is_object())
        h << largest(o["crown"]["outcomes"]) << ": " << o["crown"]["verdict"].get<std::string>();
      h << "</td></tr>";
    }
  }
  h << "</table><h3>Height map over object cells</h3><table><tr><th>method</th><th>coverage</th><th>MAE m</th><th>bias "
       "m</th></tr>";
  for (const char* m : {"sensed_only", "inpainting", "boundary_estimation"}) {
    if (!r["height_baselines"].contains(m)) continue;
    const auto& b = r["height_baselines"][m];
    h << "<tr><td style=\"text-align:left\">" << m << "</td><td>" << fmt(b["coverage"]) << "</td><td>"
      << fmt(b["mae_m"]) << "</td><td>" << fmt(b["bias_m"]) << "</td></tr>";
  }
  h << "</table><p>Boundary coverage: " << fmt(r["boundary_coverage_before"]) << " sensed only, "
    << fmt(r["boundary_coverage"]) << " after recovery (the paper reports 0.734 and 0.913 on its scenes).</p>";
  // height maps before / after / truth, one colour scale
  const auto& verts = p.mesh().vertices();
  if (!verts.empty()) {
    const auto [lo_cell, hi_cell] = p.mesh().cellBounds();
    const int x0 = lo_cell.x(), y0 = lo_cell.y(), x1 = hi_cell.x(), y1 = hi_cell.y();
    const int step = std::max(1, std::max(x1 - x0, y1 - y0) / 400);
    const int cols = (x1 - x0) / step + 1, rows = (y1 - y0) / step + 1;
    cv::Mat before(rows, cols, CV_32FC1, cv::Scalar(std::nanf(""))), after = before.clone(), truth_map = before.clone();
    double lo = 1e9, hi = -1e9;
    const double cell = p.map().voxelSize();
    for (const auto& v : verts) {
      const int c = (v.cell.x() - x0) / step, rr = rows - 1 - (v.cell.y() - y0) / step;
      before.at<float>(rr, c) = v.sensed_height;
      after.at<float>(rr, c) = v.height();
      lo = std::min(lo, static_cast<double>(v.sensed_height));
      hi = std::max(hi, static_cast<double>(v.height()));
    }
    for (const auto& roof : p.roofCells()) {
      const int c = (roof.cell.x() - x0) / step, rr = rows - 1 - (roof.cell.y() - y0) / step;
      if (c < 0 || rr < 0 || c >= cols || rr >= rows) continue;
      after.at<float>(rr, c) = roof.height;
      hi = std::max(hi, static_cast<double>(roof.height));
    }
    for (int rr = 0; rr < rows; ++rr) {
      for (int c = 0; c < cols; ++c) {
        const double t = world.surfaceHeight((x0 + c * step + 0.5) * cell, (y0 + (rows - 1 - rr) * step + 0.5) * cell);
        truth_map.at<float>(rr, c) = static_cast<float>(t);
        if (std::isfinite(t)) hi = std::max(hi, t);
      }
    }
    h << "<h2>Height maps</h2>" << img(renderHeightMap(before, lo, hi, "sensed only"), "before")
      << img(renderHeightMap(after, lo, hi, "after boundary estimation and footprint completion"), "after")
      << img(renderHeightMap(truth_map, lo, hi, "truth"), "truth");
    std::vector<double> eb, ea;
    for (const auto& v : verts) {
      const auto t = eval::cellTruth(world, (v.cell.x() + 0.5) * cell, (v.cell.y() + 0.5) * cell, cell);
      if (!t.object || !std::isfinite(t.top)) continue;
      eb.push_back(v.sensed_height - t.top);
      ea.push_back(v.height() - t.top);
    }
    h << img(histogram(eb, ea, -40, 10, 50), "error histogram");
  }
  // timing (Figure 11)
  std::vector<double> total, seg, voxels;
  const double period_ms = eval::sensingPeriodMs(p.records());
  for (const auto& rec : p.records())
    total.push_back(rec.total_ms), seg.push_back(rec.segmentation_ms), voxels.push_back(rec.voxels / 1000.0);
  h << "<h2>Timing per frame</h2>"
    << img(lineChart(
               {{"total", total}, {"ground segmentation", seg}}, period_ms,
               "processing time per frame (red: the sensing period, " + std::to_string(std::lround(period_ms)) + " ms)",
               "ms"),
           "timing")
    << img(lineChart({{"voxels in the map (thousands)", voxels}}, 0.0, "voxels", "k"), "voxels")
    << "<table><tr><th>stage</th><th>median ms</th><th>p95 ms</th></tr>";
  for (auto it = r["timing"].begin(); it != r["timing"].end(); ++it) {
    if (!it.value().is_object()) continue;
    h << "<tr><td style=\"text-align:left\">" << it.key() << "</td><td>" << fmt(it.value()["median_ms"]) << "</td><td>"
      << fmt(it.value()["p95_ms"]) << "</td></tr>";
  }
  h << "</table>";
  // boundary overlays: true top boundary green, recovered mesh projected red
  h << "<h2>Boundaries on camera frames</h2><p>Green: true object top boundary; red: raised mesh vertices at their "
       "recovered height, orange: roof cells of completed footprints, projected with the true camera pose.</p>";
  for (const auto& c : truth.cameras) {
    cv::Mat bgr;
    cv::cvtColor(c.rgb, bgr, cv::COLOR_RGB2BGR);
    for (int v = 1; v < c.segmentation.rows; ++v) {
      for (int u = 0; u < c.segmentation.cols; ++u) {
        const int g = c.segmentation.at<std::uint16_t>(v, u) - 1,
                  above = c.segmentation.at<std::uint16_t>(v - 1, u) - 1;
        if (g != above && scenes::isObjectClass(world.geomClass(g))) {
          bgr.at<cv::Vec3b>(v, u) = cv::Vec3b(0, 220, 0);
        }
      }
    }
    const Pose camera_from_world = c.world_from_camera.inverse();
    const CameraIntrinsics& k = eval::intrinsicsOf(p.calibration(), c);
    const double cell = p.map().voxelSize();
    for (const auto& m : verts) {
      if (!m.raised()) continue;
      const auto px =
          project(k, camera_from_world * Point3((m.cell.x() + 0.5) * cell, (m.cell.y() + 0.5) * cell, m.height()));
      if (px)
        cv::circle(bgr, {static_cast<int>(px->x()), static_cast<int>(px->y())}, 1, cv::Scalar(0, 0, 255), cv::FILLED);
    }
    for (const auto& roof : p.roofCells()) {
      const auto px = project(
          k, camera_from_world * Point3((roof.cell.x() + 0.5) * cell, (roof.cell.y() + 0.5) * cell, roof.height));
      if (px) bgr.at<cv::Vec3b>(static_cast<int>(px->y()), static_cast<int>(px->x())) = cv::Vec3b(0, 140, 255);
    }
    h << img(bgr, "frame " + std::to_string(c.frame) + ", camera " + p.calibration().cameras.at(c.camera).name);
  }
  h << "</body></html>\n";
  return h.str();
}

}  // namespace terrain::app
