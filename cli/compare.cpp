// `parode compare RUN.traj REFERENCE.traj`: the error metrics of a recorded run
// against a recorded reference (both written by `parode run --trajectory`),
// printed and optionally written as JSON. The same block that
// `parode run --reference` puts into the run report under `error`.
// Trade-off: comparing recorded files costs disk space (24 bytes per body per
// observed step) but lets one reference serve a whole sweep.
#include <iostream>

#include "cli_common.hpp"
#include "io/error_metrics.hpp"
#include "run/report.hpp"

namespace parode::cli {
namespace {

int compare_command(const CompareArgs& a) {
    check_output_path("--report", a.report);
    Trajectory run, ref;
    try {
        run = read_trajectory(a.run);
        ref = read_trajectory(a.reference);
    } catch (const std::runtime_error& e) {
        throw std::invalid_argument(e.what());
    }
    nlohmann::json error;
    try {
        error = compare_trajectories(run, ref, a.horizons);
    } catch (const std::runtime_error& e) {
        throw std::invalid_argument(a.run + " against " + a.reference + ": " + e.what());
    }
    error["run"] = run.meta;
    error["run"].erase("catom_mask");
    if (!a.quiet) print_error_summary(std::cout, error);
    if (!a.report.empty()) write_report(a.report, nlohmann::json{{"error", error}});
    return 0;
}

}  // namespace

void add_compare(CLI::App& app, CompareArgs& a, std::function<int()>& action) {
    CLI::App* cmd = app.add_subcommand("compare", "Error of a recorded run against a recorded reference run");
    cmd->add_option("run", a.run, "Trajectory of the run (parode run --trajectory FILE)")->required();
    cmd->add_option("reference", a.reference, "Trajectory of the reference run of the same scene")->required();
    cmd->add_option("--report", a.report, "Write {\"error\": ...} as JSON to this file");
    cmd->add_option("--horizons", a.horizons, "Steps of the run after which to report position error, e.g. 10,50,200")
        ->delimiter(',')->check(int_in(1, kMaxSteps))->capture_default_str();
    cmd->add_flag("--quiet,-q", a.quiet, "Print nothing");
    cmd->callback([&] { action = [&] { return compare_command(a); }; });
}

}  // namespace parode::cli
