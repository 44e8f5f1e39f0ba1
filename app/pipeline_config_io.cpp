#include "app/pipeline_config_io.hpp"

#include "rig/file_io.hpp"
#include "rig/settings_io.hpp"

#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <utility>
#include <vector>

namespace terrain::app {

namespace {

using io::above;
using io::atLeast;
using io::closed;
using io::offOr;
using io::openClosed;
using io::Range;

template <class E>
using Choices = std::initializer_list<std::pair<const char*, E>>;

// Every pipeline setting, once: its name (section.field, as in the YAML file, --set and
// report.json), its member and the values it may take. Reading YAML and --set, validate() and the
// JSON are all derived from this list; a setting added to a config struct is added here alone.
// Relations between settings are checked in validate().
template <class Visit>
void forEachSetting(PipelineConfig& c, Visit&& v) {
  using Histogram = GroundSegmentationConfig::Histogram;
  using Solver = GroundSegmentationConfig::Solver;
  v.integer("segment_every", c.segment_every, atLeast(1));
  // pose
  v.number("pose.heading_baseline", c.pose.heading_baseline, openClosed(0, 100, "m"));
  v.number("pose.level_min_range", c.pose.level_min_range, closed(0, 1000, "m"));
  v.number("pose.level_max_range", c.pose.level_max_range, openClosed(0, 1000, "m"));
  v.number("pose.level_cell", c.pose.level_cell, openClosed(0, 100, "m"));
  v.number("pose.smoothing_window", c.pose.smoothing_window, closed(0, 100, "s"));
  v.number("pose.level_pitch_sigma", c.pose.level_pitch_sigma, openClosed(0, 1, "rad"));
  v.number("pose.max_speed", c.pose.max_speed, openClosed(0, 1000, "m/s"));
  // voxel map
  v.number("voxel_map.voxel_size", c.voxel_map.voxel_size, closed(0.02, 5, "m"));
  // ground segmentation
  v.choice("ground.histogram", c.ground.histogram,
           Choices<Histogram>{{"local", Histogram::Local}, {"global", Histogram::Global}});
  v.choice("ground.solver", c.ground.solver, Choices<Solver>{{"icm", Solver::Icm}, {"mincut", Solver::MinCut}});
  v.number("ground.bin_size", c.ground.bin_size, openClosed(0, 5, "m"));
  v.number("ground.delta", c.ground.delta, openClosed(0, 10, "m"));
  v.number("ground.range_margin", c.ground.range_margin, openClosed(0, 20, "m"));
  v.number("ground.stack_height", c.ground.stack_height, offOr(10, "m"));
  v.number("ground.stack_gap", c.ground.stack_gap, closed(0, 5, "m"));
  v.number("ground.step_height", c.ground.step_height, offOr(5, "m"));
  v.number("ground.depth_below", c.ground.depth_below, offOr(100, "m"));
  v.number("ground.rise_above", c.ground.rise_above, offOr(100, "m"));
  v.flag("ground.lower_envelope", c.ground.lower_envelope);
  v.number("ground.point_rise", c.ground.point_rise, offOr(10, "m"));
  v.number("ground.point_reach", c.ground.point_reach, closed(0, 10, "m"));
  v.number("ground.tile_size", c.ground.tile_size, closed(1, 1000, "m"));
  v.integer("ground.tile_radius", c.ground.tile_radius, closed(0, 10));
  v.integer("ground.histogram_stride", c.ground.histogram_stride, closed(1, 8));
  v.number("ground.alpha", c.ground.alpha, above(0));
  v.number("ground.beta", c.ground.beta, above(0));
  v.number("ground.gamma", c.ground.gamma, above(0));
  v.integer("ground.icm_iterations", c.ground.icm_iterations, closed(1, 1000));
  v.integer("ground.threads", c.ground.threads, closed(0, 1024, "(0: all cores)"));
  v.number("ground.defer_share", c.ground.defer_share, closed(0, 1));
  // boundary detection
  v.number("boundary.a", c.boundary.a, closed(-1000, 1000));
  v.number("boundary.b", c.boundary.b, closed(-1000, 1000));
  v.number("boundary.kx", c.boundary.kx, above(0));
  v.number("boundary.ky", c.boundary.ky, above(0));
  v.number("boundary.threshold", c.boundary.threshold, above(0, "grey levels"));
  v.integer("boundary.erode_width", c.boundary.erode_width, closed(1, 15, "px"));
  v.integer("boundary.erode_height", c.boundary.erode_height, closed(1, 15, "px"));
  v.integer("boundary.dilate_width", c.boundary.dilate_width, closed(1, 15, "px"));
  v.integer("boundary.dilate_height", c.boundary.dilate_height, closed(1, 15, "px"));
  v.flag("boundary.erode_all_directions", c.boundary.erode_all_directions);
  v.flag("boundary.erode_sloping", c.boundary.erode_sloping);
  v.integer("boundary.foliage_margin", c.boundary.foliage_margin, closed(0, 255, "grey levels"));
  // boundary estimation
  v.number("estimation.max_distance", c.estimation.max_distance, above(0, "m"));
  v.number("estimation.max_height", c.estimation.max_height, above(0, "m"));
  v.integer("estimation.top_margin", c.estimation.top_margin, closed(0, 100, "px"));
  v.count("estimation.max_estimates", c.estimation.max_estimates, closed(1, 1000));
  v.number("estimation.fusion_quantile", c.estimation.fusion_quantile, closed(0, 1));
  v.flag("estimation.clear_line", c.estimation.clear_line);
  v.flag("estimation.require_sky_above", c.estimation.require_sky_above);
  v.integer("estimation.sky_blue_margin", c.estimation.sky_blue_margin, closed(0, 255, "grey levels"));
  v.integer("estimation.sky_min_brightness", c.estimation.sky_min_brightness, closed(0, 255, "grey levels"));
  v.flag("estimation.foliage_tops", c.estimation.foliage_tops);
  v.integer("estimation.foliage_margin", c.estimation.foliage_margin, closed(0, 255, "grey levels"));
  v.number("estimation.spread_distance", c.estimation.spread_distance, closed(0, 200, "m"));
  v.number("estimation.parallax_slope", c.estimation.parallax_slope, closed(0, 10, "m per m"));
  v.number("estimation.parallax_change", c.estimation.parallax_change, closed(0, 100, "m"));
  v.number("estimation.parallax_min_gap", c.estimation.parallax_min_gap, closed(0, 1e4, "m"));
  v.number("estimation.parallax_max_gap", c.estimation.parallax_max_gap, closed(0, 1e4, "m"));
  v.number("estimation.parallax_min_t", c.estimation.parallax_min_t, closed(0, 1e6, "standard errors"));
  v.flag("estimation.hold_young_crowns", c.estimation.hold_young_crowns);
  // footprint completion
  v.flag("footprint.enabled", c.footprint.enabled);
  v.number("footprint.min_side", c.footprint.min_side, above(0, "m"));
  v.number("footprint.wall_tolerance", c.footprint.wall_tolerance, closed(0, 10, "m"));
  v.number("footprint.wall_band", c.footprint.wall_band, closed(0, 10, "m"));
  v.number("footprint.min_wall_share", c.footprint.min_wall_share, closed(0, 1));
  v.number("footprint.min_side_support", c.footprint.min_side_support, closed(0, 1));
  v.number("footprint.max_inside_share", c.footprint.max_inside_share, closed(0, 1));
  v.integer("footprint.min_raised", c.footprint.min_raised, atLeast(1));
  v.number("footprint.min_raised_share", c.footprint.min_raised_share, closed(0, 1));
  // crown completion
  v.flag("crown.enabled", c.crown.enabled);
  v.choice("crown.cue", c.crown.cue,
           Choices<CrownConfig::Cue>{{"foliage", CrownConfig::Cue::Foliage}, {"sky", CrownConfig::Cue::Sky}});
  v.integer("crown.foliage_margin", c.crown.foliage_margin, closed(0, 255, "grey levels"));
  v.number("crown.max_trunk_gap", c.crown.max_trunk_gap, closed(0, 100, "m"));
  v.number("crown.max_trunk_width", c.crown.max_trunk_width, openClosed(0, 10, "m"));
  v.number("crown.max_grown_width", c.crown.max_grown_width, openClosed(0, 20, "m"));
  v.number("crown.min_trunk_height", c.crown.min_trunk_height, closed(0, 20, "m"));
  v.number("crown.min_radius", c.crown.min_radius, closed(0, 50, "m"));
  v.number("crown.max_radius", c.crown.max_radius, openClosed(0, 50, "m"));
  v.integer("crown.min_samples", c.crown.min_samples, atLeast(1));
  v.number("crown.max_top_spread", c.crown.max_top_spread, atLeast(0));
  v.integer("crown.min_height_px", c.crown.min_height_px, atLeast(1, "px"));
  v.number("crown.min_baseline", c.crown.min_baseline, atLeast(0, "m"));
  v.number("crown.max_offcentre", c.crown.max_offcentre, closed(0, 0.5));
  v.number("crown.max_width_to_depth", c.crown.max_width_to_depth, closed(0, 10));
  v.flag("crown.one_sided", c.crown.one_sided);
  v.flag("crown.sky_guard", c.crown.sky_guard);
  v.flag("crown.guard_estimates", c.crown.guard_estimates);
  v.number("crown.guard_cell", c.crown.guard_cell, closed(0.1, 5, "m"));
  v.flag("crown.cut_off_tops", c.crown.cut_off_tops);
  v.number("crown.cut_off_quantile", c.crown.cut_off_quantile, closed(0, 1));
  v.number("crown.radius_quantile", c.crown.radius_quantile, closed(0, 1));
  v.number("crown.radius_agreement", c.crown.radius_agreement, closed(0, 10));
  v.number("crown.agreement_bearings", c.crown.agreement_bearings, closed(0, 3.2, "rad"));
  v.flag("crown.axis_ceiling", c.crown.axis_ceiling);
  v.flag("crown.column_tops", c.crown.column_tops);
  v.number("crown.column_radius_quantile", c.crown.column_radius_quantile, closed(0, 1));
  v.number("crown.column_min_bare", c.crown.column_min_bare, closed(0, 50, "m"));
  v.flag("crown.grown_owners", c.crown.grown_owners);
  v.flag("crown.cap_bounds_trunk", c.crown.cap_bounds_trunk);
  v.flag("crown.ellipse_radius", c.crown.ellipse_radius);
  v.number("crown.ellipse_min_depth", c.crown.ellipse_min_depth, closed(0.01, 1));
  v.number("crown.ceiling_halfwidth", c.crown.ceiling_halfwidth, closed(0, 5, "m"));
  // the crowns' visual hull
  v.flag("hull.enabled", c.hull.enabled);
  v.number("hull.cell", c.hull.cell, closed(0.05, 5, "m"));
  v.number("hull.layer", c.hull.layer, closed(0.05, 5, "m"));
  v.number("hull.max_height", c.hull.max_height, openClosed(0, 200, "m"));
  v.number("hull.max_radius", c.hull.max_radius, openClosed(0, 50, "m"));
  v.number("hull.max_distance", c.hull.max_distance, openClosed(0, 500, "m"));
  v.integer("hull.min_views", c.hull.min_views, closed(1, 10000));
  v.number("hull.min_parallax", c.hull.min_parallax, closed(0, 3.14, "rad"));
  v.number("hull.min_foliage_share", c.hull.min_foliage_share, closed(0, 1));
  v.number("hull.max_sky_share", c.hull.max_sky_share, closed(0, 1));
  v.number("hull.horizon_margin", c.hull.horizon_margin, closed(-0.5, 0.5, "rad"));
  v.number("hull.horizon_distance", c.hull.horizon_distance, closed(0, 1000, "m"));
  // free space from the sky
  v.flag("free_space.enabled", c.free_space.enabled);
  v.number("free_space.min_distance", c.free_space.min_distance, closed(0, 100, "m"));
  v.number("free_space.max_distance", c.free_space.max_distance, closed(0, 500, "m"));
  v.number("free_space.margin", c.free_space.margin, closed(0, 10, "m"));
}

// The setters the YAML file and --set go through, by name.
struct SetterTable {
  std::map<std::string, io::Setter> setters;

  void number(const char* name, double& f, const Range& r) { setters[name] = io::numberSetter(f, r); }
  void integer(const char* name, int& f, const Range& r) { setters[name] = io::integerSetter(f, r); }
  void count(const char* name, std::size_t& f, const Range& r) {
    setters[name] = [&f, r](const YAML::Node& n) {
      const long long v = n.as<long long>();
      if (v < 0) throw YAML::Exception(n.Mark(), "expected a whole number from 0");
      if (!r.contains(static_cast<double>(v))) throw io::OutOfRange(static_cast<double>(v), r.text());
      f = static_cast<std::size_t>(v);
    };
  }
  void flag(const char* name, bool& f) {
    setters[name] = [&f](const YAML::Node& n) { f = n.as<bool>(); };
  }
  template <class E>
  void choice(const char* name, E& f, Choices<E> choices) {
    std::vector<std::pair<std::string, E>> list(choices.begin(), choices.end());
    setters[name] = [&f, list](const YAML::Node& n) {
      const std::string s = n.as<std::string>();
      std::string names;
      for (const auto& [text, value] : list) {
        if (s == text) return void(f = value);
        names += (names.empty() ? "" : " or ") + text;
      }
      throw YAML::Exception(n.Mark(), "expected " + names);
    };
  }
};

std::map<std::string, io::Setter> setters(PipelineConfig& c) {
  SetterTable t;
  forEachSetting(c, t);
  return std::move(t.setters);
}

// Throws io::InputError for the first setting outside its range.
struct RangeCheck {
  void number(const char* name, double& f, const Range& r) { io::requireInRange(r.contains(f), name, f, r.text()); }
  void integer(const char* name, int& f, const Range& r) { io::requireInRange(r.contains(f), name, f, r.text()); }
  void count(const char* name, std::size_t& f, const Range& r) {
    const double v = static_cast<double>(f);
    io::requireInRange(r.contains(v), name, v, r.text());
  }
  void flag(const char*, bool&) {}
  template <class E>
  void choice(const char*, E&, Choices<E>) {}
};

// Each setting under its section in a JSON object.
struct JsonWriter {
  nlohmann::json j = nlohmann::json::object();

  nlohmann::json& at(const std::string& name) { return io::settingEntry(j, name); }
  void number(const char* name, double& f, const Range&) { at(name) = f; }
  void integer(const char* name, int& f, const Range&) { at(name) = f; }
  void count(const char* name, std::size_t& f, const Range&) { at(name) = f; }
  void flag(const char* name, bool& f) { at(name) = f; }
  template <class E>
  void choice(const char* name, E& f, Choices<E> choices) {
    for (const auto& [text, value] : choices) {
      if (f == value) at(name) = text;
    }
  }
};

// Each setting's name, kind and what it allows.
struct Describer {
  std::vector<SettingInfo> out;

  void number(const char* name, double&, const Range& r) { out.push_back({name, "number", r.text()}); }
  void integer(const char* name, int&, const Range& r) { out.push_back({name, "integer", r.text()}); }
  void count(const char* name, std::size_t&, const Range& r) { out.push_back({name, "integer", r.text()}); }
  void flag(const char* name, bool&) { out.push_back({name, "flag", "true or false"}); }
  template <class E>
  void choice(const char* name, E&, Choices<E> choices) {
    std::string names;
    for (const auto& [text, value] : choices) names += (names.empty() ? "" : " or ") + std::string(text);
    out.push_back({name, "choice", names});
  }
};

}  // namespace

void validate(const PipelineConfig& config) {
  PipelineConfig c = config;
  forEachSetting(c, RangeCheck{});
  // relations between settings
  constexpr auto require = io::requireInRange;
  require(c.pose.level_max_range > c.pose.level_min_range, "pose.level_max_range", c.pose.level_max_range,
          "(pose.level_min_range, 1000] m");
  require(c.boundary.a != 0, "boundary.a", c.boundary.a, "non-zero");
  require(c.boundary.b != 0, "boundary.b", c.boundary.b, "non-zero");
  require(c.boundary.kx < c.boundary.ky, "boundary.kx", c.boundary.kx, "(0, boundary.ky)");
  require(c.estimation.parallax_min_gap <= c.estimation.parallax_max_gap, "estimation.parallax_min_gap",
          c.estimation.parallax_min_gap, "[0, estimation.parallax_max_gap] m");
  require(c.crown.max_grown_width >= c.crown.max_trunk_width, "crown.max_grown_width", c.crown.max_grown_width,
          "[crown.max_trunk_width, 20] m");
  require(c.crown.min_radius <= c.crown.max_radius, "crown.min_radius", c.crown.min_radius, "[0, crown.max_radius] m");
  require(c.hull.max_height / c.hull.layer <= 1000, "hull.max_height", c.hull.max_height,
          "(0, 200] m and at most 1000 layers of hull.layer");
  require(c.hull.max_radius / c.hull.cell <= 200, "hull.max_radius", c.hull.max_radius,
          "(0, 50] m and at most 200 cells of hull.cell");
  require(c.free_space.max_distance >= c.free_space.min_distance, "free_space.max_distance", c.free_space.max_distance,
          "[free_space.min_distance, 500] m");
}

std::vector<SettingInfo> pipelineSettings() {
  PipelineConfig c;
  Describer d;
  forEachSetting(c, d);
  return std::move(d.out);
}

void loadPipelineConfig(const std::filesystem::path& path, PipelineConfig& c) {
  io::applySettings(path, setters(c),
                    "pose, voxel_map, ground, boundary, estimation, footprint, crown, hull, free_space");
}

void applyPipelineSetting(const std::string& key_value, PipelineConfig& c, const std::string& option) {
  io::applySetting(key_value, setters(c), option);
}

std::string pipelineConfigToJson(const PipelineConfig& config) {
  PipelineConfig c = config;
  JsonWriter w;
  forEachSetting(c, w);
  return w.j.dump();
}

}  // namespace terrain::app
