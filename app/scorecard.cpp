#include "app/scorecard.hpp"

#include "evaluation/metrics.hpp"

#include <iomanip>
#include <iostream>
#include <string>
#include <utility>

namespace terrain::app {

void printScorecard(std::ostream& out, const nlohmann::json& r) {
  out << std::fixed << std::setprecision(3) << "scorecard\n";
  if (r.contains("pose") && r["pose"]["frames"].get<std::size_t>() > 0) {
    const auto& p = r["pose"];
    out << "  pose at " << p["frames"].get<std::size_t>() << " kept camera frames, error median (max):";
    for (const auto& [key, what] : {std::pair<const char*, const char*>{"horizontal_error_m", "m across"},
                                    {"vertical_error_m", "m up"},
                                    {"heading_error_deg", "deg heading"},
                                    {"pitch_error_deg", "deg pitch"},
                                    {"roll_error_deg", "deg roll"}}) {
      out << " " << p[key]["median"].get<double>() << " (" << p[key]["max"].get<double>() << ") " << what << ";";
    }
    out << "\n";
  }
  out << "  ground segmentation per voxel    F1     IoU    precision  recall\n";
  for (const char* m : eval::kGroundMethods) {
    if (!r["ground_segmentation"].contains(m)) continue;  // baselines not asked for
    const auto& g = r["ground_segmentation"][m];
    out << "    " << std::left << std::setw(28) << m << std::right << g["f1"].get<double>() << "  "
        << g["iou"].get<double>() << "  " << g["precision"].get<double>() << "      " << g["recall"].get<double>()
        << "\n";
  }
  for (const auto& w : r.value("truth_warnings", nlohmann::json::array()))
    std::cerr << "terrain: warning: " << w.get<std::string>() << "\n";
  const auto& h = r["height_recovery"];
  if (h["after"]["cells"].get<std::size_t>() == 0) {
    out << "  object heights: no object cells, not scored\n";
  } else {
    out << "  object heights (" << h["after"]["cells"].get<std::size_t>()
        << " cells)   MAE m   RMSE m  bias m   variance m2\n";
    for (const char* k : {"before", "after"}) {
      out << "    " << std::left << std::setw(28)
          << (std::string(k) == "before" ? "sensed only" : "boundary estimation") << std::right
          << h[k]["mae_m"].get<double>() << "  " << h[k]["rmse_m"].get<double>() << "  " << h[k]["bias_m"].get<double>()
          << "  " << h[k]["variance_m2"].get<double>() << "\n";
    }
    out << "    cells that got an estimate: " << h["estimated_cells"]["after"]["cells"].get<std::size_t>() << ", MAE "
        << h["estimated_cells"]["before"]["mae_m"].get<double>() << " -> "
        << h["estimated_cells"]["after"]["mae_m"].get<double>()
        << " m; terrain cells wrongly raised: " << h["raised_terrain_cells"].get<std::size_t>() << "\n";
  }
  if (h.contains("by_kind")) {
    out << "    by kind:";
    for (const auto& [kind, e] : h["by_kind"].items()) {
      out << " " << kind << " " << e["before"]["mae_m"].get<double>() << " -> " << e["after"]["mae_m"].get<double>()
          << " m (" << e["after"]["cells"].get<std::size_t>() << " cells);";
    }
    out << " sensed as terrain (under crowns): " << h["object_cells_sensed_as_terrain"].get<std::size_t>()
        << " cells\n";
  }
  if (h.contains("by_camera_view")) {
    out << "    cells whose sensed top the camera saw:";
    for (const char* k : {"building_in_camera_view", "tree_in_camera_view"}) {
      if (!h["by_camera_view"].contains(k)) continue;
      const auto& e = h["by_camera_view"][k];
      out << " " << std::string(k).substr(0, std::string(k).find('_')) << " " << e["before"]["mae_m"].get<double>()
          << " -> " << e["after"]["mae_m"].get<double>() << " m (" << e["raised_cells"].get<std::size_t>() << " of "
          << e["after"]["cells"].get<std::size_t>() << " raised);";
    }
    if (h["by_camera_view"].contains("never_in_camera_view")) {
      out << " never in view: " << h["by_camera_view"]["never_in_camera_view"]["after"]["cells"].get<std::size_t>()
          << " cells";
    }
    out << "\n    object edge cells raised (a wall or crown within 0.5 m): " << h.value("raised_edge_cells", 0) << "\n";
  }
  if (h.contains("footprints")) {
    const auto& f = h["footprints"];
    out << "    building footprints completed: " << f["completed"].get<std::size_t>() << ", roof cells "
        << f["roof_cells"].get<std::size_t>() << " (" << f["object_cells"].get<std::size_t>() << " over objects, MAE "
        << f["on_objects"]["mae_m"].get<double>() << " m; " << f["wrongly_filled_cells"].get<std::size_t>()
        << " over terrain)\n";
  }
  if (h.contains("crown_ground_vertices")) {
    out << "    ground vertices raised under tree crowns: " << h["crown_ground_vertices"].get<std::size_t>() << "\n";
  }
  if (h.contains("crown_hull")) {
    const auto& ch = h["crown_hull"];
    out << "    vertices raised by the crowns' visual hull: " << ch["raised_vertices"].get<int>() << " ("
        << ch["crown_voxels"].get<std::size_t>() << " crown voxels in " << ch["columns"].get<std::size_t>()
        << " columns)\n";
  }
  if (h.contains("sky_ceiling")) {
    out << "    raised vertices lowered to the sky's ceiling: " << h["sky_ceiling"]["lowered_vertices"].get<int>()
        << " (of " << h["sky_ceiling"]["vertices_with_ceiling"].get<std::size_t>() << " vertices with a ceiling)\n";
  }
  if (h.contains("object_tops")) {
    out << "    object tops the camera saw, at their real height (10 %, at least 1 m) sensed -> recovered:";
    for (const char* k : {"building", "tree"}) {
      const auto& t = h["object_tops"][k];
      out << " " << k << "s " << t["at_height_before"].get<std::size_t>() << " -> "
          << t["at_height_after"].get<std::size_t>() << " of " << t["top_seen"].get<std::size_t>() << " (too high "
          << t["too_high_before"].get<std::size_t>() << " -> " << t["too_high_after"].get<std::size_t>() << "; top MAE "
          << t["before"]["mae_m"].get<double>() << " -> " << t["after"]["mae_m"].get<double>() << " m);";
    }
    out << "\n    of those, seen in a frame with their lower part (where the lidar reaches):";
    for (const char* k : {"building", "tree"}) {
      const auto& w = h["object_tops"][k]["lower_part_seen_with_top"];
      out << " " << k << "s " << w["at_height_before"].get<std::size_t>() << " -> "
          << w["at_height_after"].get<std::size_t>() << " of " << w["objects"].get<std::size_t>() << ";";
    }
    out << "\n";
  }
  if (r["height_baselines"].contains("inpainting")) {
    const auto& b = r["height_baselines"];
    out << "  height map over object cells     coverage  MAE m\n";
    for (const char* k : {"sensed_only", "inpainting", "boundary_estimation"}) {
      out << "    " << std::left << std::setw(28) << k << std::right << b[k]["coverage"].get<double>() << "     "
          << b[k]["mae_m"].get<double>() << "\n";
    }
  }
  out << "  boundary coverage: " << r["boundary_coverage_before"].get<double>() << " sensed only, "
      << r["boundary_coverage"].get<double>() << " after recovery";
  if (r.contains("boundary_coverage_by_camera") && r["boundary_coverage_by_camera"].size() > 1) {
    out << " (";
    const char* sep = "";
    for (auto it = r["boundary_coverage_by_camera"].begin(); it != r["boundary_coverage_by_camera"].end(); ++it) {
      out << sep << it.key() << " " << it.value()["after"].get<double>();
      sep = ", ";
    }
    out << ")";
  }
  out << "\n"
      << "  per frame: median " << r["timing"]["total"]["median_ms"].get<double>() << " ms, p95 "
      << r["timing"]["total"]["p95_ms"].get<double>() << " ms (sensing period "
      << r["timing"].value("sensing_period_ms", 0.0) << " ms)\n";
}

}  // namespace terrain::app
