#pragma once
// The scorecard a scored run prints on the terminal, read from its report (report.json's fields,
// docs/evaluation.md).

#include <nlohmann/json.hpp>

#include <ostream>

namespace terrain::app {

void printScorecard(std::ostream& out, const nlohmann::json& report);

}  // namespace terrain::app
