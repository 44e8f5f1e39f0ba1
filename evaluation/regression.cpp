#include "evaluation/regression.hpp"

#include "evaluation/metrics.hpp"
#include "rig/file_io.hpp"

#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>

namespace terrain::eval {

namespace fs = std::filesystem;

Suite loadSuite(const fs::path& path) {
  YAML::Node root;
  try {
    root = YAML::Load(io::readFile(path));
  } catch (const YAML::Exception& e) {
    throw io::InputError(path.string() + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  auto fail = [&](const YAML::Node& n, const std::string& what) {
    throw io::InputError(path.string() + ":" + std::to_string(n.Mark().line + 1) + ": " + what);
  };
  if (!root.IsMap()) throw io::InputError(path.string() + ": expected a map with 'scenarios' and 'metrics'");
  Suite s;
  s.name = root["name"] ? root["name"].as<std::string>() : path.stem().string();
  const int default_frames = root["frames"] ? root["frames"].as<int>() : 10;
  if (!root["scenarios"] || !root["scenarios"].IsSequence() || root["scenarios"].size() == 0) {
    throw io::InputError(path.string() + ": 'scenarios' must be a non-empty list");
  }
  for (const auto& n : root["scenarios"]) {
    ScenarioSpec sc;
    try {
      if (!n["type"]) fail(n, "scenario without 'type'");
      sc.type = n["type"].as<std::string>();
      sc.frames = n["frames"] ? n["frames"].as<int>() : default_frames;
      if (n["seeds"]) {
        for (const auto& seed : n["seeds"]) {
          sc.seed = seed.as<std::uint64_t>();
          s.scenarios.push_back(sc);
        }
        continue;
      }
      sc.seed = n["seed"] ? n["seed"].as<std::uint64_t>() : 1;
    } catch (const YAML::Exception& e) {
      fail(n, "bad scenario (" + e.msg + ")");
    }
    if (sc.frames < 1 || sc.frames > 10000) fail(n, "frames must be in [1, 10000]");
    s.scenarios.push_back(sc);
  }
  if (!root["metrics"] || !root["metrics"].IsMap() || root["metrics"].size() == 0) {
    throw io::InputError(path.string() + ": 'metrics' must map metric names to {better, tolerance}");
  }
  for (const auto& kv : root["metrics"]) {
    MetricSpec m;
    m.name = kv.first.as<std::string>();
    const YAML::Node v = kv.second;
    if (!v.IsMap() || !v["better"] || !v["tolerance"])
      fail(v, "metric '" + m.name + "' needs 'better' (higher/lower) and 'tolerance'");
    try {
      const std::string better = v["better"].as<std::string>();
      if (better != "higher" && better != "lower") fail(v, "metric '" + m.name + "': better must be higher or lower");
      m.higher_is_better = better == "higher";
      m.tolerance = v["tolerance"].as<double>();
      if (!(m.tolerance >= 0)) fail(v, "metric '" + m.name + "': tolerance must be >= 0");
      if (v["count"].IsDefined() != v["min_count"].IsDefined())
        fail(v, "metric '" + m.name + "': give 'count' (a report field) and 'min_count' together");
      if (v["count"]) {
        m.count = v["count"].as<std::string>();
        m.min_count = v["min_count"].as<double>();
        if (m.count.empty() || m.count == m.name)
          fail(v, "metric '" + m.name + "': count must name another report field");
        if (!(m.min_count >= 0)) fail(v, "metric '" + m.name + "': min_count must be >= 0");
      }
    } catch (const YAML::Exception& e) {
      fail(v, "metric '" + m.name + "': bad value (" + e.msg + ")");
    }
    s.metrics.push_back(m);
  }
  return s;
}

Results loadBaseline(const fs::path& path) {
  Results r;
  try {
    const nlohmann::json j = nlohmann::json::parse(io::readFile(path));
    for (auto sc = j.at("scenarios").begin(); sc != j.at("scenarios").end(); ++sc) {
      for (auto m = sc.value().begin(); m != sc.value().end(); ++m) r[sc.key()][m.key()] = m.value().get<double>();
    }
  } catch (const nlohmann::json::exception& e) {
    throw io::InputError(path.string() + ": not a baseline file (" + e.what() + ")");
  }
  return r;
}

Shard parseShard(const std::string& text) {
  Shard s;
  char slash = 0;
  std::istringstream in(text);
  if (!(in >> s.k >> slash >> s.n) || slash != '/' || !in.eof() || s.k < 1 || s.n < 1 || s.k > s.n || s.n > 10000) {
    throw io::InputError("--shard '" + text + "': expected K/N with 1 <= K <= N (for example 2/8)");
  }
  return s;
}

Suite shardOf(const Suite& suite, Shard shard) {
  Suite part = suite;
  part.scenarios.clear();
  for (std::size_t i = static_cast<std::size_t>(shard.k - 1); i < suite.scenarios.size();
       i += static_cast<std::size_t>(shard.n)) {
    part.scenarios.push_back(suite.scenarios[i]);
  }
  return part;
}

std::string shardJson(const Suite& suite, Shard shard) {
  nlohmann::json j;
  j["suite"] = suite.name;
  j["shard"] = shard.k;
  j["of"] = shard.n;
  j["scenarios"] = nlohmann::json::array();
  for (const auto& sc : shardOf(suite, shard).scenarios) j["scenarios"].push_back(sc.id());
  return j.dump(1) + "\n";
}

Results mergeShards(const Suite& suite, const std::vector<fs::path>& dirs) {
  Results all;
  std::map<int, fs::path> seen;  // part -> directory
  int n = 0;
  for (const fs::path& dir : dirs) {
    nlohmann::json shard;
    Results part;
    try {
      if (!fs::exists(dir / "shard.json"))
        throw io::InputError((dir / "shard.json").string() + ": missing (not a shard's output)");
      shard = nlohmann::json::parse(io::readFile(dir / "shard.json"));
      if (!fs::exists(dir / "suite_results.json")) {
        throw io::InputError((dir / "suite_results.json").string() + ": missing: shard " +
                             std::to_string(shard.value("shard", 0)) + " did not finish");
      }
      const nlohmann::json r = nlohmann::json::parse(io::readFile(dir / "suite_results.json"));
      for (auto sc = r.begin(); sc != r.end(); ++sc) {
        for (auto m = sc.value().begin(); m != sc.value().end(); ++m) part[sc.key()][m.key()] = m.value().get<double>();
      }
      if (shard.at("suite").get<std::string>() != suite.name) {
        throw io::InputError((dir / "shard.json").string() + ": a shard of suite '" +
                             shard.at("suite").get<std::string>() + "', not '" + suite.name + "'");
      }
    } catch (const nlohmann::json::exception& e) {
      throw io::InputError(dir.string() + ": not a shard's output (" + e.what() + ")");
    }
    const Shard s{shard.value("shard", 0), shard.value("of", 0)};
    if (n == 0) n = s.n;
    if (s.n != n || s.k < 1 || s.k > s.n) {
      throw io::InputError((dir / "shard.json").string() + ": part " + std::to_string(s.k) + " of " +
                           std::to_string(s.n) + ", but the other shards split the suite in " + std::to_string(n));
    }
    if (const auto it = seen.find(s.k); it != seen.end()) {
      throw io::InputError(dir.string() + ": shard " + std::to_string(s.k) + "/" + std::to_string(n) +
                           " is given twice (also " + it->second.string() + ")");
    }
    seen[s.k] = dir;
    for (const auto& sc : shardOf(suite, s).scenarios) {
      const auto r = part.find(sc.id());
      if (r == part.end())
        throw io::InputError(dir.string() + ": shard " + std::to_string(s.k) + " has no results for " + sc.id());
      all[sc.id()] = r->second;
    }
  }
  for (int k = 1; k <= n; ++k) {
    if (!seen.count(k))
      throw io::InputError("shard " + std::to_string(k) + "/" + std::to_string(n) + " is missing from --merge");
  }
  if (dirs.empty()) throw io::InputError("--merge needs the shards' output directories");
  return all;
}

void writeBaseline(const fs::path& path, const Suite& suite, const Results& results, bool force) {
  // a metric no scenario reports is misspelled (or gone from the report): refused, not written as nothing
  for (const auto& m : suite.metrics) {
    for (const std::string* field : {&m.name, &m.count}) {
      if (field->empty()) continue;
      const bool anywhere =
          std::any_of(results.begin(), results.end(), [&](const auto& r) { return r.second.count(*field) > 0; });
      if (!anywhere) {
        throw io::InputError("suite " + suite.name + ": metric '" + *field + "' is in no scenario's report (" +
                             std::to_string(results.size()) + " scenarios); check its name against report.json" +
                             " (flattened with dots, e.g. ground_segmentation.gmrf_icm.f1); no baseline written");
      }
    }
  }
  nlohmann::json j;
  j["suite"] = suite.name;
  j["note"] = "written by 'terrain regress --write-baseline'; guarded metrics only";
  for (const auto& [scenario, metrics] : results) {
    for (const auto& m : suite.metrics) {
      for (const std::string* field : {&m.name, &m.count}) {
        auto it = metrics.find(*field);
        if (!field->empty() && it != metrics.end()) j["scenarios"][scenario][*field] = it->second;
      }
    }
  }
  io::writeFileAtomic(path, j.dump(1) + "\n", force);
}

RegressionResult compare(const Suite& suite, const Results& baseline, const Results& results) {
  RegressionResult out;
  for (const auto& sc : suite.scenarios) {
    for (const auto& m : suite.metrics) {
      Comparison c;
      c.scenario = sc.id();
      c.metric = m.name;
      c.tolerance = m.tolerance;
      c.higher_is_better = m.higher_is_better;
      const auto b = baseline.find(c.scenario);
      const auto r = results.find(c.scenario);
      const auto has = [&](const std::string& field) {
        return b != baseline.end() && r != results.end() && b->second.count(field) && r->second.count(field);
      };
      if (!has(m.name) || (!m.count.empty() && !has(m.count))) {
        c.missing = true;
        c.regressed = true;  // an unguarded metric is a failure: the baseline must be refreshed explicitly
      } else {
        c.baseline = b->second.at(m.name);
        c.value = r->second.at(m.name);
        if (!m.count.empty()) {
          c.baseline_count = b->second.at(m.count);
          c.count = r->second.at(m.count);
          c.skipped = !(c.baseline_count >= m.min_count && c.count >= m.min_count);
        }
        const double worse = m.higher_is_better ? c.baseline - c.value : c.value - c.baseline;
        c.regressed = !c.skipped && !(worse <= m.tolerance);
      }
      out.regressions += c.regressed;
      out.skipped += c.skipped;
      out.rows.push_back(c);
    }
  }
  return out;
}

void printTable(std::ostream& out, const RegressionResult& r) {
  out << std::left << std::setw(24) << "scenario" << std::setw(46) << "metric" << std::right << std::setw(11)
      << "baseline" << std::setw(11) << "value" << std::setw(11) << "tolerance"
      << "  status\n";
  for (const auto& c : r.rows) {
    out << std::left << std::setw(24) << c.scenario << std::setw(46) << c.metric << std::right << std::fixed
        << std::setprecision(4) << std::setw(11) << c.baseline << std::setw(11) << c.value << std::setw(11)
        << c.tolerance << "  "
        << (c.missing     ? "MISSING"
            : c.regressed ? "REGRESSED"
            : c.skipped   ? "skipped"
                          : "ok");
    if (c.skipped) out << " (count " << std::setprecision(0) << c.baseline_count << " -> " << c.count << ")";
    out << "\n";
  }
  out << r.regressions << " regressions in " << r.rows.size() - r.skipped << " checks";
  if (r.skipped > 0) out << ", " << r.skipped << " skipped (too few to compare)";
  out << "\n";
}

std::string suiteSummaryHtml(const Suite& suite, const Results& results) {
  std::ostringstream h;
  h << std::fixed << std::setprecision(3) << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>suite "
    << suite.name
    << "</title><style>body{font-family:sans-serif}table{border-collapse:collapse}td,th{border:1px solid #bbb;"
       "padding:3px 8px;text-align:right}th{background:#eee}</style></head><body><h1>Suite "
    << suite.name << "</h1><h2>Ground segmentation F1 per voxel</h2><table><tr><th>scenario</th>";
  for (const char* m : kGroundMethods) h << "<th>" << m << "</th>";
  h << "</tr>";
  auto value = [&](const std::map<std::string, double>& r, const std::string& k) -> std::string {
    auto it = r.find(k);
    if (it == r.end()) return "-";
    std::ostringstream v;
    v << std::fixed << std::setprecision(3) << it->second;
    return v.str();
  };
  for (const auto& [scenario, r] : results) {
    h << "<tr><td style=\"text-align:left\">" << scenario << "</td>";
    for (const char* m : kGroundMethods)
      h << "<td>" << value(r, std::string("ground_segmentation.") + m + ".f1") << "</td>";
    h << "</tr>";
  }
  h << "</table><h2>Object heights and boundaries</h2><table><tr><th>scenario</th><th>MAE sensed m</th><th>MAE after "
       "m</th>"
       "<th>estimated cells MAE sensed m</th><th>estimated cells MAE after m</th><th>height map MAE inpainting m</th>"
       "<th>boundary coverage sensed</th><th>boundary coverage after</th><th>median ms per frame</th></tr>";
  for (const auto& [scenario, r] : results) {
    h << "<tr><td style=\"text-align:left\">" << scenario << "</td>";
    for (const char* k :
         {"height_recovery.before.mae_m", "height_recovery.after.mae_m", "height_recovery.estimated_cells.before.mae_m",
          "height_recovery.estimated_cells.after.mae_m", "height_baselines.inpainting.mae_m",
          "boundary_coverage_before", "boundary_coverage", "timing.total.median_ms"}) {
      h << "<td>" << value(r, k) << "</td>";
    }
    h << "</tr>";
  }
  h << "</table><p>Each scenario's full report.html is in its own output directory.</p></body></html>\n";
  return h.str();
}

std::string junitXml(const Suite& suite, const RegressionResult& r) {
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuite name=\"" << suite.name << "\" tests=\"" << r.rows.size()
    << "\" failures=\"" << r.regressions << "\" skipped=\"" << r.skipped << "\">\n";
  for (const auto& c : r.rows) {
    x << "  <testcase classname=\"" << c.scenario << "\" name=\"" << c.metric << "\">";
    if (c.regressed) {
      x << "<failure message=\"" << (c.missing ? "no baseline or value" : "past tolerance") << "\">baseline "
        << c.baseline << ", value " << c.value << ", tolerance " << c.tolerance << " ("
        << (c.higher_is_better ? "higher" : "lower") << " is better)</failure>";
    } else if (c.skipped) {
      x << "<skipped message=\"too few to compare: count " << c.baseline_count << " in the baseline, " << c.count
        << " now\"/>";
    }
    x << "</testcase>\n";
  }
  x << "</testsuite>\n";
  return x.str();
}

}  // namespace terrain::eval
