#pragma once
// The pipeline configuration from YAML (sections pose, voxel_map, ground, boundary, estimation,
// footprint, crown, hull, free_space, plus segment_every), from --set KEY=VALUE, checked, and as
// JSON for reports and the run state: all from one list of the settings (pipeline_config_io.cpp).

#include "core/pipeline.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace terrain::app {

// Overlays the keys present in the file onto config. Throws io::InputError naming the file, line
// and key for unknown keys, bad values and values out of range.
void loadPipelineConfig(const std::filesystem::path& path, PipelineConfig& config);

// Overlays one "key=value" setting (the YAML name, e.g. crown.cue=sky) given with the command-line
// option `option`. Throws io::InputError naming the option and the setting for an unknown key or a bad
// value; ranges are checked by validate().
void applyPipelineSetting(const std::string& key_value, PipelineConfig& config, const std::string& option);

// Throws io::InputError naming the first field outside its range.
void validate(const PipelineConfig& config);

// The same fields and names as the YAML file (JSON is YAML: the result loads as a config file).
std::string pipelineConfigToJson(const PipelineConfig& config);

// One setting: its name (section.field), its kind (number, integer, flag, choice) and the values
// it allows, as error messages state them.
struct SettingInfo {
  std::string name, kind, allowed;
};
// Every setting, in the order of the one list that reading, checking and writing them derive from.
std::vector<SettingInfo> pipelineSettings();

}  // namespace terrain::app
