// A thin validating reader over toml11 values: every error names the file, the
// line, the dotted key and what was expected; unknown keys are errors too.
// `--set key=value` overrides are applied to the parsed tree before validation,
// so they pass through the same checks.
// Trade-off: values are read eagerly into plain structs (no lazy lookups), so a
// scene is fully validated before any ODE object exists.
#pragma once
#include <toml.hpp>

#include <initializer_list>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "scene/scene.hpp"
#include "util/errors.hpp"

namespace parode {

// A table (or value) with the dotted path that led to it.
class Node {
public:
    Node(const toml::value& v, std::string path) : v_(&v), path_(std::move(path)) {}

    const toml::value& value() const { return *v_; }
    const std::string& path() const { return path_; }
    std::string key_path(const std::string& key) const;
    bool has(const std::string& key) const;
    Node at(const std::string& key) const;  // required key
    Node index(std::size_t i) const;        // array element

    // Fails if the table has keys outside `allowed` (the readers pass
    // table_keys(...) of scene_keys.hpp, so the reference lists every key).
    void expect_keys(const std::vector<std::string>& allowed) const;
    void require_table() const;
    std::size_t array_size() const;  // fails unless an array

    double number(const std::string& key, double def, double lo = -kInf, double hi = kInf) const;
    double number_required(const std::string& key, double lo = -kInf, double hi = kInf) const;
    long integer(const std::string& key, long def, long lo, long hi) const;
    bool boolean(const std::string& key, bool def) const;
    std::string string(const std::string& key, const std::string& def) const;
    std::string choice(const std::string& key, const std::string& def,
                       std::initializer_list<const char*> options) const;
    Vec3 vec3(const std::string& key, const Vec3& def) const;
    // Each component within [-bound, bound]; `what` says what was expected.
    Vec3 vec3(const std::string& key, const Vec3& def, double bound, const std::string& what) const;
    // Euclidean length at most `max_length`.
    Vec3 vec3_length(const std::string& key, const Vec3& def, double max_length, const std::string& what) const;

    [[noreturn]] void fail(const std::string& key, const std::string& expected) const;
    [[noreturn]] void fail_here(const std::string& message) const;
    // Like fail(), with the value found described by the caller.
    [[noreturn]] void fail_value(const std::string& key, const std::string& expected, const std::string& got) const;

    static constexpr double kInf = std::numeric_limits<double>::infinity();

private:
    double to_number(const Node& n, const std::string& what) const;
    const toml::value* v_;
    std::string path_;
};

// "file:line" of a value (or just the file when the value has no location).
std::string where(const toml::value& v);
std::string describe(const toml::value& v);

// Parse a scene file; syntax errors become SceneError with file and line.
toml::value parse_toml_file(const std::string& path);
// Apply "a.b.c=value" (value in TOML syntax, or a bare word taken as a string).
void apply_override(toml::value& root, const std::string& assignment);

}  // namespace parode
