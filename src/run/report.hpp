// The run report: a JSON document (for analysis/) and a human summary table,
// built from the same data so the two never disagree.
// Trade-off: the JSON is assembled once at the end of a run; nothing is
// streamed, so a crashed run leaves no partial report (errors are printed).
#pragma once
#include <nlohmann/json.hpp>

#include <ostream>
#include <string>

#include "run/pipeline.hpp"

namespace parode {

// What the report needs beyond the pipeline (its threads and ranks are the
// pipeline's execution and collectives).
struct RunInfo {
    std::string scene_path;
    double wall_s = 0;
};

nlohmann::json build_info();
nlohmann::json make_report(const Scene& scene, const Pipeline& pipeline, const RunInfo& info);
void print_summary(std::ostream& os, const nlohmann::json& report);
// The `error` block (error_metrics.hpp) as a few summary lines.
void print_error_summary(std::ostream& os, const nlohmann::json& error);
// Writes the report; throws std::runtime_error naming the file on failure.
void write_report(const std::string& path, const nlohmann::json& report);

}  // namespace parode
