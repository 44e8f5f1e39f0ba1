#include "app/pipeline_config_io.hpp"
#include "rig/file_io.hpp"
#include "tests/test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <set>
#include <string>

namespace terrain::app {
namespace {

// the JSON value at "section.field"
const nlohmann::json& at(const nlohmann::json& j, const std::string& name) {
  const auto dot = name.find('.');
  return dot == std::string::npos ? j.at(name) : j.at(name.substr(0, dot)).at(name.substr(dot + 1));
}

// Every setting is written to the JSON, and nothing else is.
TEST(PipelineConfigIoTest, TheJsonHoldsEverySettingAndNothingElse) {
  const nlohmann::json j = nlohmann::json::parse(pipelineConfigToJson(PipelineConfig{}));
  std::set<std::string> listed, written;
  for (const auto& s : pipelineSettings()) listed.insert(s.name);
  for (const auto& [key, value] : j.items()) {
    if (!value.is_object()) {
      written.insert(key);
      continue;
    }
    for (const auto& [field, v] : value.items()) written.insert(key + "." + field);
  }
  EXPECT_EQ(listed, written);
  EXPECT_FALSE(listed.empty());
  // settings that were once missing from the file or from the report
  for (const char* name : {"pose.level_cell", "pose.smoothing_window", "ground.stack_gap", "hull.min_parallax"})
    EXPECT_TRUE(listed.count(name)) << name;
}

// Each setting, changed through --set, comes out of the JSON with its new value, and the JSON read
// back as a settings file gives the same JSON: its setter and its writer address the same member.
TEST(PipelineConfigIoTest, EverySettingRoundTripsThroughTheJson) {
  const PipelineConfig defaults;
  const nlohmann::json before = nlohmann::json::parse(pipelineConfigToJson(defaults));
  PipelineConfig changed;
  std::map<std::string, nlohmann::json> expected;
  for (const auto& s : pipelineSettings()) {
    const nlohmann::json& old = at(before, s.name);
    std::string value;
    if (s.kind == "flag") {
      value = old.get<bool>() ? "false" : "true";
      expected[s.name] = !old.get<bool>();
    } else if (s.kind == "choice") {
      // the other of "a or b"
      const std::string a = s.allowed.substr(0, s.allowed.find(" or ")),
                        b = s.allowed.substr(s.allowed.find(" or ") + 4);
      value = old.get<std::string>() == a ? b : a;
      expected[s.name] = value;
    } else if (s.kind == "integer" || s.kind == "number") {
      // up a step, or down where that leaves the range (min_wall_share is 1 at most)
      const double step = s.kind == "integer" ? 1 : 0.125;
      for (const double v : {old.get<double>() + step, old.get<double>() - step}) {
        value = s.kind == "integer" ? std::to_string(static_cast<long long>(v)) : nlohmann::json(v).dump();
        expected[s.name] = v;
        try {
          applyPipelineSetting(s.name + "=" + value, changed, "--set");
          break;
        } catch (const io::InputError&) {
          if (v < old.get<double>()) throw;
        }
      }
      continue;
    } else {
      FAIL() << s.name << ": kind " << s.kind;
    }
    applyPipelineSetting(s.name + "=" + value, changed, "--set");
  }
  const nlohmann::json after = nlohmann::json::parse(pipelineConfigToJson(changed));
  for (const auto& [name, v] : expected) EXPECT_EQ(at(after, name), v) << name;
  test::TempDir dir;
  io::writeFileAtomic(dir / "config.json", after.dump(1), false);
  PipelineConfig loaded;
  loadPipelineConfig(dir / "config.json", loaded);
  EXPECT_EQ(nlohmann::json::parse(pipelineConfigToJson(loaded)), after);
}

// The defaults are within every range; each number refuses NaN by name as it is read (from --set,
// and from a file with its line), and a value out of range is refused with the range as the list
// states it, as it is read and by validate() (a value set in code).
TEST(PipelineConfigIoTest, RangesComeFromTheList) {
  EXPECT_NO_THROW(validate(PipelineConfig{}));
  test::TempDir dir;
  for (const auto& s : pipelineSettings()) {
    if (s.kind != "number") continue;
    PipelineConfig c;
    try {
      applyPipelineSetting(s.name + "=.nan", c, "--set");
      ADD_FAILURE() << "--set " << s.name << "=.nan passed";
    } catch (const io::InputError& e) {
      EXPECT_EQ(std::string(e.what()), "--set " + s.name + "=.nan: nan is out of range (allowed: " + s.allowed + ")");
    }
    // in a file, with its line
    const auto dot = s.name.find('.');
    io::writeFileAtomic(dir / "nan.yaml",
                        "# NaN\n" + s.name.substr(0, dot) + ":\n  " + s.name.substr(dot + 1) + ": .nan\n", true);
    try {
      loadPipelineConfig(dir / "nan.yaml", c);
      ADD_FAILURE() << s.name << ": .nan passed";
    } catch (const io::InputError& e) {
      EXPECT_NE(
          std::string(e.what()).find("nan.yaml:3: " + s.name + " = nan is out of range (allowed: " + s.allowed + ")"),
          std::string::npos)
          << e.what();
    }
  }
  PipelineConfig c;
  EXPECT_THROW(applyPipelineSetting("pose.level_cell=0", c, "--set"), io::InputError);
  c.pose.level_cell = 0;
  EXPECT_THROW(validate(c), io::InputError);
  c = PipelineConfig{};
  applyPipelineSetting("ground.stack_height=0", c, "--set");  // 0 is off
  EXPECT_NO_THROW(validate(c));
  try {
    applyPipelineSetting("ground.stack_height=-0.1", c, "--set");
    ADD_FAILURE() << "ground.stack_height = -0.1 passed";
  } catch (const io::InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "--set ground.stack_height=-0.1: -0.1 is out of range (allowed: 0 (off) or (0, 10] m)");
  }
  EXPECT_EQ(c.ground.stack_height, 0);  // a refused value changes nothing
  c.ground.stack_height = -0.1;
  try {
    validate(c);
    ADD_FAILURE() << "ground.stack_height = -0.1 passed";
  } catch (const io::InputError& e) {
    EXPECT_EQ(std::string(e.what()), "ground.stack_height = -0.1 is out of range (allowed: 0 (off) or (0, 10] m)");
  }
  // relations between settings
  c = PipelineConfig{};
  applyPipelineSetting("crown.min_radius=9", c, "--set");  // above crown.max_radius (8 m)
  EXPECT_THROW(validate(c), io::InputError);
  // a count below zero is refused as it is read
  EXPECT_THROW(applyPipelineSetting("estimation.max_estimates=-1", c, "--set"), io::InputError);
}

}  // namespace
}  // namespace terrain::app
