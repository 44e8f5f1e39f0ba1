#pragma once
// Settings files: YAML maps of sections (or top-level keys) whose dotted names ("lidar.max_range")
// select a setter. Shared by every configuration that YAML fills.

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <functional>
#include <map>
#include <string>

namespace terrain::io {

using Setter = std::function<void(const YAML::Node&)>;

// Applies every key of the file through its setter. Throws InputError naming the file and line for
// invalid YAML, an unknown key, a key given twice or a value its setter refuses. `sections` names the expected sections
// for the message about a file that is not a map.
void applySettings(const std::filesystem::path& path, const std::map<std::string, Setter>& setters,
                   const std::string& sections);

// Applies one "key=value" setting given on the command line (the value read as YAML, as in a file).
// Throws InputError naming `option` and the setting for a missing '=', an unknown key or a bad value.
void applySetting(const std::string& key_value, const std::map<std::string, Setter>& setters,
                  const std::string& option);

// Throws InputError "<field> = <value> is out of range (allowed: <range>)" unless ok.
void requireInRange(bool ok, const std::string& field, double value, const std::string& range);

// Setters for plain fields.
inline Setter numberSetter(double& f) {
  return [&f](const YAML::Node& n) { f = n.as<double>(); };
}
inline Setter integerSetter(int& f) {
  return [&f](const YAML::Node& n) { f = n.as<int>(); };
}

}  // namespace terrain::io
