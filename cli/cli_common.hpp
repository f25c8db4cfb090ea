// Shared pieces of the command line: exit codes, thread resolution, the error
// guard that turns exceptions into messages and exit codes, and subcommands
// defined in their own files.
// Trade-off: exceptions carry the message; only this guard decides exit codes.
#pragma once
#include <CLI/CLI.hpp>

#include <functional>
#include <string>

namespace parode::cli {

constexpr int kExitSimulation = 1;
constexpr int kExitUsage = 2;
constexpr int kExitScene = 3;
constexpr int kExitOutput = 4;

int resolve_threads(int requested);  // 0 -> OMP_NUM_THREADS or 1
std::string backend_list();
int guarded(const std::function<int()>& action);

struct BenchArgs {
    std::string what;
    std::string scene;
    std::vector<std::string> sets;
    std::vector<std::string> backends;
    std::vector<int> threads;
    int steps = 0;
    int every = 50;
    int repeats = 5;
    std::string csv;
};
void add_bench(CLI::App& app, BenchArgs& a, std::function<int()>& action);

}  // namespace parode::cli
