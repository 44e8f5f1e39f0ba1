#pragma once
// Settings files: YAML maps of sections (or top-level keys) whose dotted names ("lidar.max_range")
// select a setter. Shared by every configuration that YAML fills.

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
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

// Thrown by a setter for a value outside its setting's range; what() is "<value> is out of range
// (allowed: <range>)", which applySettings and applySetting put after the file:line (or the option)
// and the setting's name.
class OutOfRange : public std::runtime_error {
 public:
  OutOfRange(double value, const std::string& range);
};

// The values a number may take: finite, from lo to hi, either end open or closed; with `off`, 0
// too (the setting's "off").
struct Range {
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  double lo = -kInf, hi = kInf;
  bool lo_open = false, hi_open = false, off = false;
  const char* unit = "";

  bool contains(double v) const {
    if (!std::isfinite(v)) return false;
    if (off && v == 0) return true;
    return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  }
  // as error messages state it: "[0, 100] m", "> 0 m", "0 (off) or (0, 10] m"
  std::string text() const {
    const auto g = [](double x) {
      std::ostringstream o;
      o << x;
      return o.str();
    };
    std::string t;
    if (lo == -kInf && hi == kInf) {
      t = "a finite number";
    } else if (hi == kInf) {
      t = (lo_open ? "> " : ">= ") + g(lo);
    } else {
      t = std::string(off ? "0 (off) or " : "") + (lo_open ? "(" : "[") + g(lo) + ", " + g(hi) + (hi_open ? ")" : "]");
    }
    return *unit ? t + " " + unit : t;
  }
};
inline Range closed(double lo, double hi, const char* unit = "") { return {lo, hi, false, false, false, unit}; }
inline Range openClosed(double lo, double hi, const char* unit = "") { return {lo, hi, true, false, false, unit}; }
inline Range closedOpen(double lo, double hi, const char* unit = "") { return {lo, hi, false, true, false, unit}; }
inline Range openOpen(double lo, double hi, const char* unit = "") { return {lo, hi, true, true, false, unit}; }
inline Range above(double lo, const char* unit = "") { return {lo, Range::kInf, true, false, false, unit}; }
inline Range atLeast(double lo, const char* unit = "") { return {lo, Range::kInf, false, false, false, unit}; }
inline Range offOr(double hi, const char* unit = "") { return {0, hi, true, false, true, unit}; }

// A setting's entry in a JSON object (nlohmann::json): j[section][field] for "section.field",
// j[name] for a top-level name.
template <class Json>
Json& settingEntry(Json& j, const std::string& name) {
  const auto dot = name.find('.');
  return dot == std::string::npos ? j[name] : j[name.substr(0, dot)][name.substr(dot + 1)];
}

// Setters for plain fields, refusing a value outside `range` (by default: any finite one) where it
// is read, so that the error can name its line.
inline Setter numberSetter(double& f, const Range& range = {}) {
  return [&f, range](const YAML::Node& n) {
    const double v = n.as<double>();
    if (!range.contains(v)) throw OutOfRange(v, range.text());
    f = v;
  };
}
inline Setter integerSetter(int& f, const Range& range = {}) {
  return [&f, range](const YAML::Node& n) {
    const int v = n.as<int>();
    if (!range.contains(v)) throw OutOfRange(v, range.text());
    f = v;
  };
}

}  // namespace terrain::io
