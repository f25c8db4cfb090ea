// How the tests run the parode binary, in one place: `parode ARGS` as a
// shell command (in a folder, with an environment, under a launcher, with a
// time limit), its exit code and what it printed on stdout and stderr; and
// a JSON file (run report, info) read whole.
// Trade-off: a shell command line, as a user types it, instead of fork/exec:
// quoting is the caller's, and each run is a whole process start-up.
#pragma once
#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "scratch_dir.hpp"

namespace parode::test {

struct Run {
    std::string args;              // after `parode`
    std::string env;               // "NAME=value ..." (or `env -u NAME ...`) before the command
    std::string launcher;          // e.g. "mpiexec -n 2 --oversubscribe "
    std::filesystem::path dir;     // where it runs and its output files go (required)
    int timeout_s = 0;             // > 0: killed after that many seconds (`timeout`)
};

struct Result {
    int rc = -1;  // the exit code; -1 when a signal ended it
    std::string out, err;
};

inline Result run_parode(const Run& r) {
    namespace fs = std::filesystem;
    const fs::path out = r.dir / "stdout.txt", err = r.dir / "stderr.txt";
    const std::string limit = r.timeout_s > 0 ? "timeout -k 5 " + std::to_string(r.timeout_s) + " " : "";
    const std::string cmd = "cd '" + r.dir.string() + "' && " + (r.env.empty() ? "" : "env " + r.env + " ") + limit +
                            r.launcher + "'" + PARODE_BINARY + "' " + r.args + " >'" + out.string() + "' 2>'" +
                            err.string() + "'";
    const int status = std::system(cmd.c_str());
    Result res;
    res.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    res.out = slurp(out);
    res.err = slurp(err);
    return res;
}

// The JSON document of a file; throws (fails the test) unless valid JSON.
inline nlohmann::json read_json(const std::filesystem::path& path) { return nlohmann::json::parse(slurp(path)); }

}  // namespace parode::test
