#include "rig/settings_io.hpp"

#include "rig/file_io.hpp"

#include <sstream>

namespace terrain::io {

void applySettings(const std::filesystem::path& path, const std::map<std::string, Setter>& setters,
                   const std::string& sections) {
  YAML::Node root;
  try {
    root = YAML::Load(readFile(path));
  } catch (const YAML::Exception& e) {
    throw InputError(path.string() + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (root.IsNull()) return;
  if (!root.IsMap()) throw InputError(path.string() + ": expected a map of sections (" + sections + ")");
  std::map<std::string, int> seen;  // key -> line it was first given on (YAML keeps both of a repeated key)
  auto apply = [&](const std::string& key, const YAML::Node& value) {
    const int line = value.Mark().line + 1;
    const auto [first, fresh] = seen.emplace(key, line);
    if (!fresh) {
      throw InputError(path.string() + ":" + std::to_string(line) + ": '" + key + "' is given twice (first on line " +
                       std::to_string(first->second) + ")");
    }
    auto it = setters.find(key);
    if (it == setters.end()) {
      throw InputError(path.string() + ":" + std::to_string(value.Mark().line + 1) + ": unknown setting '" + key + "'");
    }
    try {
      it->second(value);
    } catch (const OutOfRange& e) {
      throw InputError(path.string() + ":" + std::to_string(value.Mark().line + 1) + ": " + key + " = " + e.what());
    } catch (const YAML::Exception& e) {
      // the line of the value, or of the part of it (a camera's field) the setter names
      const int at = e.mark.is_null() ? value.Mark().line : e.mark.line;
      throw InputError(path.string() + ":" + std::to_string(at + 1) + ": '" + key + "' has a bad value (" + e.msg +
                       ")");
    }
  };
  // a key is a plain scalar ('? [a, b]: 1' or an empty '? :' is no setting's name)
  const auto keyOf = [&](const YAML::Node& key) {
    if (!key.IsScalar() || key.Scalar().empty()) {
      throw InputError(path.string() + ":" + std::to_string(key.Mark().line + 1) +
                       ": a key that is not a setting's name");
    }
    return key.Scalar();
  };
  for (const auto& kv : root) {
    const std::string key = keyOf(kv.first);
    if (kv.second.IsMap()) {
      for (const auto& inner : kv.second) apply(key + "." + keyOf(inner.first), inner.second);
    } else {
      apply(key, kv.second);
    }
  }
}

void applySetting(const std::string& key_value, const std::map<std::string, Setter>& setters,
                  const std::string& option) {
  const auto eq = key_value.find('=');
  const std::string where = option + " " + key_value;
  if (eq == std::string::npos || eq == 0) throw InputError(where + ": expected KEY=VALUE");
  const std::string key = key_value.substr(0, eq);
  const auto it = setters.find(key);
  if (it == setters.end()) throw InputError(where + ": unknown setting '" + key + "'");
  try {
    it->second(YAML::Load(key_value.substr(eq + 1)));
  } catch (const OutOfRange& e) {
    throw InputError(where + ": " + e.what());
  } catch (const YAML::Exception& e) {
    throw InputError(where + ": '" + key + "' has a bad value (" + e.msg + ")");
  }
}

namespace {

std::string outOfRange(double value, const std::string& range) {
  std::ostringstream s;
  s << value << " is out of range (allowed: " << range << ")";
  return s.str();
}

}  // namespace

OutOfRange::OutOfRange(double value, const std::string& range) : std::runtime_error(outOfRange(value, range)) {}

void requireInRange(bool ok, const std::string& field, double value, const std::string& range) {
  if (!ok) throw InputError(field + " = " + outOfRange(value, range));
}

}  // namespace terrain::io
