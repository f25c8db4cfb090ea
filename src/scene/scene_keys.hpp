// The scene-file reference as data: every key the reader accepts, with its
// table, type, unit, range, default and meaning, in one table. The readers
// (scene_file.cpp, generators.cpp, scene_checks.cpp) accept exactly the keys
// listed here (Node::expect_keys(table_keys(...))), `parode keys` prints the
// table as Markdown for the README, and tests/test_scene_keys.cpp loads every
// bound and default against the readers.
// Trade-off: the reader still applies each range itself (a key's checks stay
// next to the code that uses it); the table restates them and the test keeps
// the two equal, rather than the reader being driven by the table.
#pragma once
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace parode {

// What a numeric range bounds: the value, each component of a [x, y, z], or
// its length.
enum class KeyBound { Value, Each, Length };

struct SceneKey {
    // The table as written in TOML: "" (the top level), "scene",
    // "solver.auto_disable", "[[bodies]]", "[[bodies]].rotation",
    // "[[checks.position]]"...
    std::string table;
    std::string key;
    std::string type;  // "number", "integer", "string", "bool", "[x, y, z]", "one of ...", "table"...
    std::string unit;  // SI, or "" for none
    std::string range;  // as the reference shows it
    // The range as numbers: NaN when not numeric, -inf / +inf when open.
    // Where `depends_on` is set, these are their values at the defaults of
    // the keys it names (catoms.spacing >= catoms.radius: lo = 0.5).
    double lo, hi;
    bool lo_inclusive = true, hi_inclusive = true;
    KeyBound bound = KeyBound::Value;
    std::string default_text;  // "required", "unset", "2 x radius", "0.5"...
    double default_value;      // NaN when the default is not a plain number
    std::string depends_on;    // keys the range or default depends on ("scene.dt")
    std::string meaning;       // one line
};

// Every key, table by table, in the order the readers list them.
const std::vector<SceneKey>& scene_keys();
// The tables in order of first appearance ("" first).
std::vector<std::string> scene_tables();
// The keys of one table, in order; empty for an unknown table.
std::vector<std::string> table_keys(const std::string& table);
// One Markdown table per TOML table, each under a heading line.
std::string scene_keys_markdown();
// The table as JSON: an array of objects (lo, hi and default_value only when
// finite).
nlohmann::json scene_keys_json();

}  // namespace parode
