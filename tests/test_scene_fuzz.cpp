// Fuzz test of the scene reader through the real executable: seeded random
// mutations of the classic scenes and the hard cases (extreme numbers, deleted
// keys, duplicated tables, swapped types, truncation, junk bytes), each run as
// `parode run FILE --steps 5 -q --threads 1 --report R` with a time limit.
// Every outcome must be a clean exit: 0 (or 5, a hard case's [checks] failing)
// with finite diagnostics in the report; 3 with a scene error naming the file;
// 1 with the guard's message; 6 with a memory message. A signal, another
// code, a hang, a report with non-finite numbers or an ODE assertion (which
// the command line turns into exit 1: the reader should have refused the
// scene) fails the test, which keeps the mutated file and prints how to
// reproduce it.
// Trade-off: a process per case (about 10 ms) tests what a user meets, exit
// codes included, and survives crashes; catom prisms are cut to 64 so that
// 2,500 cases take about 20 s. PARODE_FUZZ_CASES and PARODE_FUZZ_SEED change
// the count and the seed.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace {

namespace fs = std::filesystem;

const std::string kSourceDir = PARODE_SOURCE_DIR;
constexpr double kTimeoutS = 30;

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream os;
    os << in.rdbuf();
    return os.str();
}

long env_long(const char* name, long def) {
    const char* v = std::getenv(name);
    return v && *v ? std::atol(v) : def;
}

// The base scenes, with catom prisms cut to at most 64 catoms.
std::vector<std::pair<std::string, std::string>> base_scenes() {
    std::vector<std::pair<std::string, std::string>> out;
    std::vector<fs::path> files = {kSourceDir + "/jobs/scenes/tennis.toml", kSourceDir + "/jobs/scenes/magnetic-tennis.toml",
                                   kSourceDir + "/jobs/scenes/buggy.toml"};
    for (const auto& e : fs::directory_iterator(kSourceDir + "/jobs/scenes/hard")) {
        if (e.path().extension() == ".toml" && e.path().stem() != "pile-100k") files.push_back(e.path());
    }
    std::sort(files.begin() + 3, files.end());
    const std::regex count(R"((^|\n)count = \d+)");
    for (const auto& f : files) out.emplace_back(f.stem().string(), std::regex_replace(slurp(f), count, "$1count = 64"));
    return out;
}

// ---- mutations -------------------------------------------------------------

using Rng = std::mt19937_64;

std::size_t pick(Rng& rng, std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); }

std::vector<std::string> split_lines(const std::string& s) {
    std::vector<std::string> lines;
    std::istringstream in(s);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
    return lines;
}

std::string join_lines(const std::vector<std::string>& lines) {
    std::string s;
    for (const auto& l : lines) s += l + "\n";
    return s;
}

// Indices of lines "key = value" (not comments, not headers).
std::vector<std::size_t> key_lines(const std::vector<std::string>& lines) {
    static const std::regex kv(R"(^\s*[A-Za-z0-9_"-]+\s*=)");
    std::vector<std::size_t> out;
    for (std::size_t i = 0; i < lines.size(); ++i) if (std::regex_search(lines[i], kv)) out.push_back(i);
    return out;
}

const char* const kExtremes[] = {"0", "-1", "1", "2", "0.5", "-0.0", "1e300", "-1e300", "1e-300", "1e309", "-1e309",
                                 "1e-400", "9223372036854775807", "-9223372036854775808", "99999999999999999999",
                                 "nan", "inf", "-inf", "1e6", "1e7", "100000000", "1e-9", "1e20", "3.0e8", "-2.5"};
const char* const kOtherTypes[] = {"\"text\"", "\"\"", "true", "false", "[1, 2]", "[]", "{ a = 1 }", "{}",
                                   "1979-05-27", "[[1], [2]]", "[0.0, 0.0]", "[\"a\", 1]"};

// Replace one number in the value part of a key line with an extreme value.
std::string mutate_number(const std::string& text, Rng& rng, std::string& log) {
    auto lines = split_lines(text);
    static const std::regex number(R"(-?\b\d+(\.\d+)?([eE][-+]?\d+)?)");
    std::vector<std::pair<std::size_t, std::smatch>> hits;
    for (std::size_t i : key_lines(lines)) {
        const std::string& l = lines[i];
        const std::size_t eq = l.find('='), hash = l.find('#', eq);
        const std::string value = l.substr(eq + 1, hash == std::string::npos ? std::string::npos : hash - eq - 1);
        if (value.find('"') != std::string::npos) continue;
        for (auto it = std::sregex_iterator(l.begin() + static_cast<long>(eq) + 1, l.begin() + static_cast<long>(eq + 1 + value.size()), number);
             it != std::sregex_iterator(); ++it) hits.emplace_back(i, *it);
    }
    if (hits.empty()) return text;
    const auto& [line, m] = hits[pick(rng, hits.size())];
    const std::string x = kExtremes[pick(rng, std::size(kExtremes))];
    const std::size_t at = static_cast<std::size_t>(m.position(0)) + 0;
    log += "number '" + m.str(0) + "' -> " + x + " on line " + std::to_string(line + 1) + "; ";
    const std::size_t eq = lines[line].find('=');
    const std::size_t pos = eq + 1 + at;
    lines[line].replace(pos, static_cast<std::size_t>(m.length(0)), x);
    return join_lines(lines);
}

// Scale one number of a key line by a large or small factor (or negate it):
// values that often pass the reader's bounds and reach ODE. Catom counts are
// left alone (the extremes above reach them): a scaled count of 64,000 runs
// for seconds.
std::string scale_number(const std::string& text, Rng& rng, std::string& log) {
    auto lines = split_lines(text);
    static const std::regex number(R"(-?\b\d+(\.\d+)?([eE][-+]?\d+)?)");
    std::vector<std::size_t> candidates;
    for (std::size_t i : key_lines(lines)) {
        const std::string& l = lines[i];
        if (l.find('"') == std::string::npos && l.find("count") == std::string::npos) candidates.push_back(i);
    }
    if (candidates.empty()) return text;
    const std::size_t i = candidates[pick(rng, candidates.size())];
    const std::size_t eq = lines[i].find('=');
    std::smatch m;
    const std::string value = lines[i].substr(eq + 1);
    if (!std::regex_search(value, m, number)) return text;
    static const double kFactors[] = {1e3, 1e-3, 1e6, 1e-6, 100, 0.01, -1, 0, 10, 1e9};
    const double f = kFactors[pick(rng, std::size(kFactors))];
    std::ostringstream x;
    x.precision(17);
    const bool integer = m.str(0).find_first_of(".eE") == std::string::npos;
    const double scaled = std::strtod(m.str(0).c_str(), nullptr) * f;  // 1e309 from an earlier mutation: inf
    if (integer && scaled == std::floor(scaled) && std::fabs(scaled) < 9e18) x << static_cast<long long>(scaled);
    else x << std::scientific << scaled;
    log += "number '" + m.str(0) + "' x " + std::to_string(f) + " -> " + x.str() + " on line " + std::to_string(i + 1) + "; ";
    lines[i].replace(eq + 1 + static_cast<std::size_t>(m.position(0)), static_cast<std::size_t>(m.length(0)), x.str());
    return join_lines(lines);
}

std::string delete_key(const std::string& text, Rng& rng, std::string& log) {
    auto lines = split_lines(text);
    const auto keys = key_lines(lines);
    if (keys.empty()) return text;
    const std::size_t i = keys[pick(rng, keys.size())];
    log += "deleted line " + std::to_string(i + 1) + " '" + lines[i] + "'; ";
    lines.erase(lines.begin() + static_cast<long>(i));
    return join_lines(lines);
}

// Append a copy of a table (its header and lines up to the next header).
std::string duplicate_table(const std::string& text, Rng& rng, std::string& log) {
    auto lines = split_lines(text);
    std::vector<std::size_t> headers;
    for (std::size_t i = 0; i < lines.size(); ++i) if (!lines[i].empty() && lines[i][0] == '[') headers.push_back(i);
    if (headers.empty()) return text;
    const std::size_t h = headers[pick(rng, headers.size())];
    std::size_t end = h + 1;
    while (end < lines.size() && (lines[end].empty() || lines[end][0] != '[')) ++end;
    log += "duplicated table '" + lines[h] + "'; ";
    lines.insert(lines.end(), lines.begin() + static_cast<long>(h), lines.begin() + static_cast<long>(end));
    return join_lines(lines);
}

std::string swap_type(const std::string& text, Rng& rng, std::string& log) {
    auto lines = split_lines(text);
    const auto keys = key_lines(lines);
    if (keys.empty()) return text;
    const std::size_t i = keys[pick(rng, keys.size())];
    const std::string v = kOtherTypes[pick(rng, std::size(kOtherTypes))];
    log += "line " + std::to_string(i + 1) + " '" + lines[i] + "' value -> " + v + "; ";
    lines[i] = lines[i].substr(0, lines[i].find('=') + 1) + " " + v;
    return join_lines(lines);
}

std::string truncate_text(const std::string& text, Rng& rng, std::string& log) {
    const std::size_t at = pick(rng, text.size() + 1);
    log += "truncated at byte " + std::to_string(at) + "; ";
    return text.substr(0, at);
}

std::string insert_junk(const std::string& text, Rng& rng, std::string& log) {
    static const char kJunk[] = {'\0', '\xff', '\xc3', '[', ']', '{', '}', '"', '\'', '=', '\n', '#', ',', '.', '\\', 'x', '7'};
    std::string junk;
    for (std::size_t n = 1 + pick(rng, 8); n > 0; --n) junk += kJunk[pick(rng, sizeof kJunk)];
    const std::size_t at = pick(rng, text.size() + 1);
    log += std::to_string(junk.size()) + " junk bytes at byte " + std::to_string(at) + "; ";
    return text.substr(0, at) + junk + text.substr(at);
}

std::string mutate(std::string text, Rng& rng, std::string& log) {
    using Mutation = std::string (*)(const std::string&, Rng&, std::string&);
    // Numbers weigh most: they reach the bounds of the reader and of ODE.
    static const Mutation kinds[] = {mutate_number, mutate_number, mutate_number, scale_number, scale_number,
                                     scale_number, scale_number, delete_key, delete_key, duplicate_table,
                                     swap_type, swap_type, truncate_text, insert_junk};
    static const std::size_t kMutations[] = {1, 1, 1, 2, 3};
    for (std::size_t n = kMutations[pick(rng, std::size(kMutations))]; n > 0; --n) {
        text = kinds[pick(rng, std::size(kinds))](text, rng, log);
    }
    return text;
}

// ---- running ---------------------------------------------------------------

struct Outcome {
    int code = -1;    // exit code, -1 when killed by a signal or timed out
    int signal = 0;
    bool timed_out = false;
    std::string err;
};

Outcome run_parode(const std::vector<std::string>& args, const fs::path& out, const fs::path& err) {
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    pid_t pid = 0;
    Outcome o;
    if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ) != 0) return o;
    posix_spawn_file_actions_destroy(&fa);
    const auto t0 = std::chrono::steady_clock::now();
    int status = 0;
    while (waitpid(pid, &status, WNOHANG) == 0) {
        if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > kTimeoutS) {
            kill(pid, SIGKILL);
            waitpid(pid, &status, 0);
            o.timed_out = true;
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    if (!o.timed_out && WIFEXITED(status)) o.code = WEXITSTATUS(status);
    if (WIFSIGNALED(status)) o.signal = WTERMSIG(status);
    o.err = slurp(err);
    return o;
}

bool finite_number(const nlohmann::json& j) { return j.is_number() && std::isfinite(j.get<double>()); }

// Empty when the report's diagnostics are all finite numbers, else what is not.
std::string report_problem(const fs::path& path) {
    nlohmann::json r;
    try {
        r = nlohmann::json::parse(slurp(path));
    } catch (const std::exception& e) {
        return std::string("report unreadable: ") + e.what();
    }
    const auto& d = r["diagnostics"];
    const nlohmann::json values[] = {d["max_penetration"], d["mean_penetration"], d["energy"]["kinetic"],
                                     d["energy"]["potential"], d["energy"]["total"], d["com_height"], r["wall_s"]};
    for (const auto& v : values) if (!finite_number(v)) return "non-finite diagnostic: " + v.dump();
    if (d["nan_count"] != 0) return "nan_count " + d["nan_count"].dump();
    return "";
}

// The outcome's class ("ok", "scene error", ...) or "BAD: why".
std::string classify(const Outcome& o, const std::string& file, const fs::path& report) {
    if (o.timed_out) return "BAD: no exit within " + std::to_string(kTimeoutS) + " s";
    if (o.signal) return "BAD: killed by signal " + std::to_string(o.signal);
    const std::string name = fs::path(file).filename().string();
    switch (o.code) {
        case 0:
        case 5: {
            const std::string p = report_problem(report);
            if (!p.empty()) return "BAD: exit " + std::to_string(o.code) + " with " + p;
            return o.code == 0 ? "0 ok" : "5 checks failed";
        }
        case 1:
            if (o.err.find("ODE stopped on an internal check") != std::string::npos) {
                return "BAD: the scene passed the reader but reached an ODE assertion";
            }
            return o.err.find("parode: simulation failed: ") != std::string::npos ? "1 simulation failed"
                                                                                   : "BAD: exit 1 without the guard's message";
        case 3:
            if (o.err.find("parode: scene error: ") == std::string::npos || o.err.find(name) == std::string::npos) {
                return "BAD: exit 3 without a scene error naming " + name;
            }
            return "3 scene error";
        case 6:
            return o.err.find("memory") != std::string::npos ? "6 memory" : "BAD: exit 6 without a memory message";
        default:
            return "BAD: exit " + std::to_string(o.code);
    }
}

TEST(SceneFuzz, EveryMutationEndsInACleanExit) {
    const long cases = env_long("PARODE_FUZZ_CASES", 2500);
    const auto seed = static_cast<std::uint64_t>(env_long("PARODE_FUZZ_SEED", 20240611));
    const fs::path dir = fs::temp_directory_path() / ("parode_fuzz_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const auto bases = base_scenes();
    std::map<std::string, int> counts;
    int bad = 0;
    for (long c = 0; c < cases; ++c) {
        Rng rng(seed + static_cast<std::uint64_t>(c));
        const auto& [name, text] = bases[pick(rng, bases.size())];
        std::string log;
        const std::string file = (dir / ("case" + std::to_string(c) + "-" + name + ".toml")).string();
        std::ofstream(file, std::ios::binary) << mutate(text, rng, log);
        const fs::path report = dir / "report.json";
        fs::remove(report);
        const Outcome o = run_parode({PARODE_BINARY, "run", file, "--steps", "5", "-q", "--threads", "1", "--report",
                                      report.string()},
                                     dir / "out.txt", dir / "err.txt");
        const std::string cls = classify(o, file, report);
        ++counts[cls.rfind("BAD", 0) == 0 ? "BAD" : cls];
        if (cls.rfind("BAD", 0) == 0) {
            ++bad;
            ADD_FAILURE() << "case " << c << " (" << name << "): " << cls << "\n  mutations: " << log
                          << "\n  kept: " << file << "\n  stderr: " << o.err.substr(0, 600);
        } else {
            fs::remove(file);
        }
    }
    std::ostringstream summary;
    summary << cases << " cases:";
    for (const auto& [k, n] : counts) summary << " " << k << " " << n << ";";
    std::cout << "[ fuzz     ] " << summary.str() << "\n";
    RecordProperty("outcomes", summary.str());
    EXPECT_EQ(bad, 0) << summary.str();
    EXPECT_GE(cases, 500) << "the fuzz test runs at least 500 cases";
    if (bad == 0) fs::remove_all(dir);
}

}  // namespace
