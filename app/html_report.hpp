#pragma once
// report.html: a self-contained page (plots embedded as PNG data URIs) with the height maps before
// and after recovery and the true one, the height error histogram, per-frame timing (like the
// paper's Figure 11), boundary overlays on camera frames and a table of every metric and baseline.

#include "core/pipeline.hpp"
#include "evaluation/report.hpp"
#include "sim/world.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace terrain::app {

// RFC 4648 base64 of data (with padding)
std::string base64(const std::vector<unsigned char>& data);

std::string htmlReport(const nlohmann::json& report, const Pipeline& pipeline, const eval::RunTruth& truth,
                       const sim::World& world, const std::string& title);

}  // namespace terrain::app
