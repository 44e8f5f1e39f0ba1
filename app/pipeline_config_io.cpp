#include "app/pipeline_config_io.hpp"

#include "rig/file_io.hpp"
#include "rig/settings_io.hpp"

#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include <map>

namespace terrain::app {

namespace {

using io::Setter;
constexpr auto require = io::requireInRange;

std::map<std::string, Setter> fields(PipelineConfig& c) {
  const auto num = io::numberSetter;
  const auto integer = io::integerSetter;
  return {
      {"segment_every", integer(c.segment_every)},
      {"pose.heading_baseline", num(c.pose.heading_baseline)},
      {"pose.level_min_range", num(c.pose.level_min_range)},
      {"pose.level_max_range", num(c.pose.level_max_range)},
      {"pose.level_pitch_sigma", num(c.pose.level_pitch_sigma)},
      {"pose.max_speed", num(c.pose.max_speed)},
      {"voxel_map.voxel_size", num(c.voxel_map.voxel_size)},
      {"ground.histogram",
       [&c](const YAML::Node& n) {
         if (!parseHistogram(n.as<std::string>(), c.ground.histogram))
           throw YAML::Exception(n.Mark(), "expected global or local");
       }},
      {"ground.solver",
       [&c](const YAML::Node& n) {
         if (!parseSolver(n.as<std::string>(), c.ground.solver))
           throw YAML::Exception(n.Mark(), "expected icm or mincut");
       }},
      {"ground.bin_size", num(c.ground.bin_size)},
      {"ground.delta", num(c.ground.delta)},
      {"ground.range_margin", num(c.ground.range_margin)},
      {"ground.stack_height", num(c.ground.stack_height)},
      {"ground.stack_gap", num(c.ground.stack_gap)},
      {"ground.depth_below", num(c.ground.depth_below)},
      {"ground.tile_size", num(c.ground.tile_size)},
      {"ground.tile_radius", integer(c.ground.tile_radius)},
      {"ground.histogram_stride", integer(c.ground.histogram_stride)},
      {"ground.alpha", num(c.ground.alpha)},
      {"ground.beta", num(c.ground.beta)},
      {"ground.gamma", num(c.ground.gamma)},
      {"ground.icm_iterations", integer(c.ground.icm_iterations)},
      {"ground.threads", integer(c.ground.threads)},
      {"ground.defer_share", num(c.ground.defer_share)},
      {"boundary.a", num(c.boundary.a)},
      {"boundary.b", num(c.boundary.b)},
      {"boundary.kx", num(c.boundary.kx)},
      {"boundary.ky", num(c.boundary.ky)},
      {"boundary.threshold", num(c.boundary.threshold)},
      {"boundary.erode_width", integer(c.boundary.erode_width)},
      {"boundary.erode_height", integer(c.boundary.erode_height)},
      {"boundary.dilate_width", integer(c.boundary.dilate_width)},
      {"boundary.dilate_height", integer(c.boundary.dilate_height)},
      {"boundary.erode_all_directions", [&c](const YAML::Node& n) { c.boundary.erode_all_directions = n.as<bool>(); }},
      {"boundary.erode_sloping", [&c](const YAML::Node& n) { c.boundary.erode_sloping = n.as<bool>(); }},
      {"boundary.foliage_margin", integer(c.boundary.foliage_margin)},
      {"estimation.max_distance", num(c.estimation.max_distance)},
      {"estimation.max_height", num(c.estimation.max_height)},
      {"estimation.top_margin", integer(c.estimation.top_margin)},
      {"estimation.fusion_quantile", num(c.estimation.fusion_quantile)},
      {"estimation.max_estimates",
       [&c](const YAML::Node& n) {
         const int v = n.as<int>();
         require(v >= 1 && v <= 1000, "estimation.max_estimates", v, "[1, 1000]");
         c.estimation.max_estimates = static_cast<std::size_t>(v);
       }},
      {"estimation.clear_line", [&c](const YAML::Node& n) { c.estimation.clear_line = n.as<bool>(); }},
      {"estimation.require_sky_above", [&c](const YAML::Node& n) { c.estimation.require_sky_above = n.as<bool>(); }},
      {"estimation.sky_blue_margin", integer(c.estimation.sky_blue_margin)},
      {"estimation.sky_min_brightness", integer(c.estimation.sky_min_brightness)},
      {"estimation.foliage_tops", [&c](const YAML::Node& n) { c.estimation.foliage_tops = n.as<bool>(); }},
      {"estimation.foliage_margin", integer(c.estimation.foliage_margin)},
      {"estimation.spread_distance", num(c.estimation.spread_distance)},
      {"estimation.parallax_slope", num(c.estimation.parallax_slope)},
      {"estimation.parallax_change", num(c.estimation.parallax_change)},
      {"estimation.parallax_min_gap", num(c.estimation.parallax_min_gap)},
      {"estimation.parallax_max_gap", num(c.estimation.parallax_max_gap)},
      {"estimation.parallax_min_t", num(c.estimation.parallax_min_t)},
      {"estimation.hold_young_crowns", [&c](const YAML::Node& n) { c.estimation.hold_young_crowns = n.as<bool>(); }},
      {"footprint.enabled", [&c](const YAML::Node& n) { c.footprint.enabled = n.as<bool>(); }},
      {"footprint.min_side", num(c.footprint.min_side)},
      {"footprint.wall_tolerance", num(c.footprint.wall_tolerance)},
      {"footprint.wall_band", num(c.footprint.wall_band)},
      {"footprint.min_wall_share", num(c.footprint.min_wall_share)},
      {"footprint.min_side_support", num(c.footprint.min_side_support)},
      {"footprint.max_inside_share", num(c.footprint.max_inside_share)},
      {"footprint.min_raised", integer(c.footprint.min_raised)},
      {"footprint.min_raised_share", num(c.footprint.min_raised_share)},
      {"crown.enabled", [&c](const YAML::Node& n) { c.crown.enabled = n.as<bool>(); }},
      {"hull.enabled", [&c](const YAML::Node& n) { c.hull.enabled = n.as<bool>(); }},
      {"hull.cell", num(c.hull.cell)},
      {"hull.layer", num(c.hull.layer)},
      {"hull.max_height", num(c.hull.max_height)},
      {"hull.max_radius", num(c.hull.max_radius)},
      {"hull.max_distance", num(c.hull.max_distance)},
      {"hull.min_views", integer(c.hull.min_views)},
      {"hull.min_parallax", num(c.hull.min_parallax)},
      {"hull.min_foliage_share", num(c.hull.min_foliage_share)},
      {"hull.max_sky_share", num(c.hull.max_sky_share)},
      {"hull.horizon_margin", num(c.hull.horizon_margin)},
      {"hull.horizon_distance", num(c.hull.horizon_distance)},
      {"free_space.enabled", [&c](const YAML::Node& n) { c.free_space.enabled = n.as<bool>(); }},
      {"free_space.min_distance", num(c.free_space.min_distance)},
      {"free_space.max_distance", num(c.free_space.max_distance)},
      {"free_space.margin", num(c.free_space.margin)},
      {"crown.cue",
       [&c](const YAML::Node& n) {
         if (!parseCrownCue(n.as<std::string>(), c.crown.cue))
           throw YAML::Exception(n.Mark(), "expected foliage or sky");
       }},
      {"crown.foliage_margin", integer(c.crown.foliage_margin)},
      {"crown.max_trunk_gap", num(c.crown.max_trunk_gap)},
      {"crown.max_trunk_width", num(c.crown.max_trunk_width)},
      {"crown.max_grown_width", num(c.crown.max_grown_width)},
      {"crown.min_trunk_height", num(c.crown.min_trunk_height)},
      {"crown.min_radius", num(c.crown.min_radius)},
      {"crown.max_radius", num(c.crown.max_radius)},
      {"crown.min_samples", integer(c.crown.min_samples)},
      {"crown.max_top_spread", num(c.crown.max_top_spread)},
      {"crown.min_height_px", integer(c.crown.min_height_px)},
      {"crown.min_baseline", num(c.crown.min_baseline)},
      {"crown.max_offcentre", num(c.crown.max_offcentre)},
  };
}

}  // namespace

void validate(const PipelineConfig& c) {
  require(c.voxel_map.voxel_size >= 0.02 && c.voxel_map.voxel_size <= 5, "voxel_map.voxel_size", c.voxel_map.voxel_size,
          "[0.02, 5] m");
  require(c.segment_every >= 1, "segment_every", c.segment_every, ">= 1");
  require(c.pose.heading_baseline > 0 && c.pose.heading_baseline <= 100, "pose.heading_baseline",
          c.pose.heading_baseline, "(0, 100] m");
  require(c.pose.max_speed > 0 && c.pose.max_speed <= 1000, "pose.max_speed", c.pose.max_speed, "(0, 1000] m/s");
  require(c.pose.level_pitch_sigma > 0 && c.pose.level_pitch_sigma <= 1, "pose.level_pitch_sigma",
          c.pose.level_pitch_sigma, "(0, 1] rad");
  require(c.ground.bin_size > 0 && c.ground.bin_size <= 5, "ground.bin_size", c.ground.bin_size, "(0, 5] m");
  require(c.ground.delta > 0 && c.ground.delta <= 10, "ground.delta", c.ground.delta, "(0, 10] m");
  require(c.ground.range_margin > 0 && c.ground.range_margin <= 20, "ground.range_margin", c.ground.range_margin,
          "(0, 20] m");
  require(c.ground.stack_height >= 0 && c.ground.stack_height <= 10, "ground.stack_height", c.ground.stack_height,
          "0 (off) or (0, 10] m");
  require(c.ground.stack_gap >= 0 && c.ground.stack_gap <= 5, "ground.stack_gap", c.ground.stack_gap, "[0, 5] m");
  require(c.ground.depth_below >= 0 && c.ground.depth_below <= 100, "ground.depth_below", c.ground.depth_below,
          "0 (off) or (0, 100] m");
  require(c.ground.tile_size >= 1 && c.ground.tile_size <= 1000, "ground.tile_size", c.ground.tile_size, "[1, 1000] m");
  require(c.ground.tile_radius >= 0 && c.ground.tile_radius <= 10, "ground.tile_radius", c.ground.tile_radius,
          "[0, 10]");
  require(c.ground.histogram_stride >= 1 && c.ground.histogram_stride <= 8, "ground.histogram_stride",
          c.ground.histogram_stride, "[1, 8]");
  require(c.ground.alpha > 0, "ground.alpha", c.ground.alpha, "> 0");
  require(c.ground.beta > 0, "ground.beta", c.ground.beta, "> 0");
  require(c.ground.gamma > 0, "ground.gamma", c.ground.gamma, "> 0");
  require(c.ground.defer_share >= 0 && c.ground.defer_share <= 1, "ground.defer_share", c.ground.defer_share, "[0, 1]");
  require(c.ground.icm_iterations >= 1 && c.ground.icm_iterations <= 1000, "ground.icm_iterations",
          c.ground.icm_iterations, "[1, 1000]");
  require(c.boundary.a != 0, "boundary.a", c.boundary.a, "non-zero");
  require(c.boundary.b != 0, "boundary.b", c.boundary.b, "non-zero");
  require(c.boundary.kx > 0 && c.boundary.kx < c.boundary.ky, "boundary.kx", c.boundary.kx, "(0, ky)");
  require(c.boundary.threshold > 0, "boundary.threshold", c.boundary.threshold, "> 0");
  for (int v : {c.boundary.erode_width, c.boundary.erode_height, c.boundary.dilate_width, c.boundary.dilate_height}) {
    require(v >= 1 && v <= 15, "boundary mask size", v, "[1, 15] px");
  }
  require(c.estimation.max_distance > 0, "estimation.max_distance", c.estimation.max_distance, "> 0 m");
  require(c.estimation.max_height > 0, "estimation.max_height", c.estimation.max_height, "> 0 m");
  require(c.estimation.parallax_slope >= 0 && c.estimation.parallax_slope <= 10, "estimation.parallax_slope",
          c.estimation.parallax_slope, "[0, 10] m per m");
  require(c.estimation.parallax_change >= 0 && c.estimation.parallax_change <= 100, "estimation.parallax_change",
          c.estimation.parallax_change, "[0, 100] m");
  require(c.estimation.parallax_min_gap >= 0 && c.estimation.parallax_min_gap <= c.estimation.parallax_max_gap,
          "estimation.parallax_min_gap", c.estimation.parallax_min_gap, "[0, estimation.parallax_max_gap] m");
  require(c.estimation.parallax_max_gap >= 0 && c.estimation.parallax_max_gap <= 1e4, "estimation.parallax_max_gap",
          c.estimation.parallax_max_gap, "[0, 10000] m");
  require(c.estimation.parallax_min_t >= 0 && c.estimation.parallax_min_t <= 1e6, "estimation.parallax_min_t",
          c.estimation.parallax_min_t, "[0, 1e6] standard errors");
  require(c.estimation.spread_distance >= 0 && c.estimation.spread_distance <= 200, "estimation.spread_distance",
          c.estimation.spread_distance, "[0, 200] m");
  require(c.footprint.min_side > 0, "footprint.min_side", c.footprint.min_side, "> 0 m");
  require(c.footprint.wall_tolerance >= 0 && c.footprint.wall_tolerance <= 10, "footprint.wall_tolerance",
          c.footprint.wall_tolerance, "[0, 10] m");
  require(c.footprint.wall_band >= 0 && c.footprint.wall_band <= 10, "footprint.wall_band", c.footprint.wall_band,
          "[0, 10] m");
  for (const auto& [name, share] : {std::pair{"footprint.min_wall_share", c.footprint.min_wall_share},
                                    {"footprint.min_side_support", c.footprint.min_side_support},
                                    {"footprint.max_inside_share", c.footprint.max_inside_share},
                                    {"footprint.min_raised_share", c.footprint.min_raised_share}}) {
    require(share >= 0 && share <= 1, name, share, "[0, 1]");
  }
  require(c.footprint.min_raised >= 1, "footprint.min_raised", c.footprint.min_raised, ">= 1");
  require(c.crown.max_trunk_width > 0 && c.crown.max_trunk_width <= 10, "crown.max_trunk_width",
          c.crown.max_trunk_width, "(0, 10] m");
  require(c.crown.max_grown_width >= c.crown.max_trunk_width && c.crown.max_grown_width <= 20, "crown.max_grown_width",
          c.crown.max_grown_width, "[crown.max_trunk_width, 20] m");
  require(c.crown.min_trunk_height >= 0 && c.crown.min_trunk_height <= 20, "crown.min_trunk_height",
          c.crown.min_trunk_height, "[0, 20] m");
  require(c.crown.min_radius >= 0 && c.crown.min_radius <= c.crown.max_radius, "crown.min_radius", c.crown.min_radius,
          "[0, crown.max_radius] m");
  require(c.crown.max_radius > 0 && c.crown.max_radius <= 50, "crown.max_radius", c.crown.max_radius, "(0, 50] m");
  require(c.crown.min_samples >= 1, "crown.min_samples", c.crown.min_samples, ">= 1");
  require(c.crown.foliage_margin >= 0 && c.crown.foliage_margin <= 255, "crown.foliage_margin", c.crown.foliage_margin,
          "[0, 255] grey levels");
  require(c.estimation.foliage_margin >= 0 && c.estimation.foliage_margin <= 255, "estimation.foliage_margin",
          c.estimation.foliage_margin, "[0, 255] grey levels");
  require(c.boundary.foliage_margin >= 0 && c.boundary.foliage_margin <= 255, "boundary.foliage_margin",
          c.boundary.foliage_margin, "[0, 255] grey levels");
  require(c.crown.max_trunk_gap >= 0 && c.crown.max_trunk_gap <= 100, "crown.max_trunk_gap", c.crown.max_trunk_gap,
          "[0, 100] m");
  require(c.crown.max_top_spread >= 0, "crown.max_top_spread", c.crown.max_top_spread, ">= 0");
  require(c.crown.min_height_px >= 1, "crown.min_height_px", c.crown.min_height_px, ">= 1 px");
  require(c.crown.min_baseline >= 0, "crown.min_baseline", c.crown.min_baseline, ">= 0 m");
  require(c.free_space.min_distance >= 0 && c.free_space.min_distance <= 100, "free_space.min_distance",
          c.free_space.min_distance, "[0, 100] m");
  require(c.free_space.max_distance >= c.free_space.min_distance && c.free_space.max_distance <= 500,
          "free_space.max_distance", c.free_space.max_distance, "[free_space.min_distance, 500] m");
  require(c.free_space.margin >= 0 && c.free_space.margin <= 10, "free_space.margin", c.free_space.margin, "[0, 10] m");
  require(c.crown.max_offcentre >= 0 && c.crown.max_offcentre <= 0.5, "crown.max_offcentre", c.crown.max_offcentre,
          "[0, 0.5]");
  require(c.hull.cell >= 0.05 && c.hull.cell <= 5, "hull.cell", c.hull.cell, "[0.05, 5] m");
  require(c.hull.layer >= 0.05 && c.hull.layer <= 5, "hull.layer", c.hull.layer, "[0.05, 5] m");
  require(c.hull.max_height > 0 && c.hull.max_height <= 200 && c.hull.max_height / c.hull.layer <= 1000,
          "hull.max_height", c.hull.max_height, "(0, 200] m and at most 1000 layers of hull.layer");
  require(c.hull.max_radius > 0 && c.hull.max_radius <= 50 && c.hull.max_radius / c.hull.cell <= 200, "hull.max_radius",
          c.hull.max_radius, "(0, 50] m and at most 200 cells of hull.cell");
  require(c.hull.max_distance > 0 && c.hull.max_distance <= 500, "hull.max_distance", c.hull.max_distance,
          "(0, 500] m");
  require(c.hull.min_views >= 1 && c.hull.min_views <= 10000, "hull.min_views", c.hull.min_views, "[1, 10000]");
  require(c.hull.min_parallax >= 0 && c.hull.min_parallax <= 3.14, "hull.min_parallax", c.hull.min_parallax,
          "[0, 3.14] rad");
  require(c.hull.min_foliage_share >= 0 && c.hull.min_foliage_share <= 1, "hull.min_foliage_share",
          c.hull.min_foliage_share, "[0, 1]");
  require(c.hull.max_sky_share >= 0 && c.hull.max_sky_share <= 1, "hull.max_sky_share", c.hull.max_sky_share, "[0, 1]");
  require(c.hull.horizon_margin >= -0.5 && c.hull.horizon_margin <= 0.5, "hull.horizon_margin", c.hull.horizon_margin,
          "[-0.5, 0.5] rad");
  require(c.hull.horizon_distance >= 0 && c.hull.horizon_distance <= 1000, "hull.horizon_distance",
          c.hull.horizon_distance, "[0, 1000] m");
  require(c.estimation.max_estimates >= 1 && c.estimation.max_estimates <= 1000, "estimation.max_estimates",
          static_cast<double>(c.estimation.max_estimates), "[1, 1000]");
  require(c.estimation.fusion_quantile >= 0 && c.estimation.fusion_quantile <= 1, "estimation.fusion_quantile",
          c.estimation.fusion_quantile, "[0, 1]");
}

void loadPipelineConfig(const std::filesystem::path& path, PipelineConfig& c) {
  io::applySettings(path, fields(c),
                    "pose, voxel_map, ground, boundary, estimation, footprint, crown, hull, free_space");
}

void applyPipelineSetting(const std::string& key_value, PipelineConfig& c, const std::string& option) {
  io::applySetting(key_value, fields(c), option);
}

std::string pipelineConfigToJson(const PipelineConfig& c) {
  nlohmann::json j;
  j["segment_every"] = c.segment_every;
  j["pose"] = {{"heading_baseline", c.pose.heading_baseline},
               {"level_min_range", c.pose.level_min_range},
               {"level_max_range", c.pose.level_max_range},
               {"level_pitch_sigma", c.pose.level_pitch_sigma},
               {"max_speed", c.pose.max_speed}};
  j["voxel_map"] = {{"voxel_size", c.voxel_map.voxel_size}};
  j["ground"] = {{"histogram", c.ground.histogram == GroundSegmentationConfig::Histogram::Local ? "local" : "global"},
                 {"solver", c.ground.solver == GroundSegmentationConfig::Solver::Icm ? "icm" : "mincut"},
                 {"bin_size", c.ground.bin_size},
                 {"delta", c.ground.delta},
                 {"range_margin", c.ground.range_margin},
                 {"stack_height", c.ground.stack_height},
                 {"stack_gap", c.ground.stack_gap},
                 {"depth_below", c.ground.depth_below},
                 {"tile_size", c.ground.tile_size},
                 {"tile_radius", c.ground.tile_radius},
                 {"histogram_stride", c.ground.histogram_stride},
                 {"alpha", c.ground.alpha},
                 {"beta", c.ground.beta},
                 {"gamma", c.ground.gamma},
                 {"icm_iterations", c.ground.icm_iterations},
                 {"threads", c.ground.threads},
                 {"defer_share", c.ground.defer_share}};
  j["boundary"] = {{"a", c.boundary.a},
                   {"b", c.boundary.b},
                   {"kx", c.boundary.kx},
                   {"ky", c.boundary.ky},
                   {"threshold", c.boundary.threshold},
                   {"erode_width", c.boundary.erode_width},
                   {"erode_height", c.boundary.erode_height},
                   {"dilate_width", c.boundary.dilate_width},
                   {"dilate_height", c.boundary.dilate_height},
                   {"erode_all_directions", c.boundary.erode_all_directions},
                   {"erode_sloping", c.boundary.erode_sloping},
                   {"foliage_margin", c.boundary.foliage_margin}};
  j["estimation"] = {{"max_distance", c.estimation.max_distance},
                     {"max_height", c.estimation.max_height},
                     {"top_margin", c.estimation.top_margin},
                     {"max_estimates", c.estimation.max_estimates},
                     {"fusion_quantile", c.estimation.fusion_quantile},
                     {"clear_line", c.estimation.clear_line},
                     {"require_sky_above", c.estimation.require_sky_above},
                     {"sky_blue_margin", c.estimation.sky_blue_margin},
                     {"sky_min_brightness", c.estimation.sky_min_brightness},
                     {"foliage_tops", c.estimation.foliage_tops},
                     {"foliage_margin", c.estimation.foliage_margin},
                     {"spread_distance", c.estimation.spread_distance},
                     {"parallax_slope", c.estimation.parallax_slope},
                     {"parallax_change", c.estimation.parallax_change},
                     {"parallax_min_gap", c.estimation.parallax_min_gap},
                     {"parallax_max_gap", c.estimation.parallax_max_gap},
                     {"parallax_min_t", c.estimation.parallax_min_t},
                     {"hold_young_crowns", c.estimation.hold_young_crowns}};
  j["footprint"] = {{"enabled", c.footprint.enabled},
                    {"min_side", c.footprint.min_side},
                    {"wall_tolerance", c.footprint.wall_tolerance},
                    {"wall_band", c.footprint.wall_band},
                    {"min_wall_share", c.footprint.min_wall_share},
                    {"min_side_support", c.footprint.min_side_support},
                    {"max_inside_share", c.footprint.max_inside_share},
                    {"min_raised", c.footprint.min_raised},
                    {"min_raised_share", c.footprint.min_raised_share}};
  j["crown"] = {{"enabled", c.crown.enabled},
                {"cue", c.crown.cue == CrownConfig::Cue::Foliage ? "foliage" : "sky"},
                {"foliage_margin", c.crown.foliage_margin},
                {"max_trunk_gap", c.crown.max_trunk_gap},
                {"max_trunk_width", c.crown.max_trunk_width},
                {"max_grown_width", c.crown.max_grown_width},
                {"min_trunk_height", c.crown.min_trunk_height},
                {"min_radius", c.crown.min_radius},
                {"max_radius", c.crown.max_radius},
                {"min_samples", c.crown.min_samples},
                {"max_top_spread", c.crown.max_top_spread},
                {"min_height_px", c.crown.min_height_px},
                {"min_baseline", c.crown.min_baseline},
                {"max_offcentre", c.crown.max_offcentre}};
  j["hull"] = {{"enabled", c.hull.enabled},
               {"cell", c.hull.cell},
               {"layer", c.hull.layer},
               {"max_height", c.hull.max_height},
               {"max_radius", c.hull.max_radius},
               {"max_distance", c.hull.max_distance},
               {"min_views", c.hull.min_views},
               {"min_parallax", c.hull.min_parallax},
               {"min_foliage_share", c.hull.min_foliage_share},
               {"max_sky_share", c.hull.max_sky_share},
               {"horizon_margin", c.hull.horizon_margin},
               {"horizon_distance", c.hull.horizon_distance}};
  j["free_space"] = {{"enabled", c.free_space.enabled},
                     {"min_distance", c.free_space.min_distance},
                     {"max_distance", c.free_space.max_distance},
                     {"margin", c.free_space.margin}};
  return j.dump();
}

}  // namespace terrain::app
