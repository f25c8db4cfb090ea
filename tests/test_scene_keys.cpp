// The scene-key table (scene/scene_keys.hpp) against the readers: every
// numeric bound it states loads at the bound and fails just past it with a
// message naming the key; every default it states, written out, leaves a
// small magnetic pile's state hash after 5 steps unchanged; a key outside the
// table is refused; joint parameters match the ODE mapping.
// Trade-off: one small base scene per table, with the key under test written
// into it, rather than a scene per key: a base that needs another key set
// (a capsule for `length`) says so in kContext. Keys that cannot be tested
// this way are listed with the reason, and the lists are checked against the
// table so that a new key needs a decision.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "scene/generators.hpp"
#include "scene/scene_file.hpp"
#include "scene/scene_keys.hpp"
#include "test_support.hpp"

namespace {

using parode::SceneKey;

// A scene as TOML sections (header and "key = value" lines), in order.
struct Section {
    std::string header;
    std::vector<std::string> lines;
};

struct SceneText {
    std::vector<Section> sections;

    SceneText& add(const std::string& header, std::vector<std::string> lines = {}) {
        sections.push_back({header, std::move(lines)});
        return *this;
    }
    // The last section with `header`.
    Section& last(const std::string& header) {
        for (auto it = sections.rbegin(); it != sections.rend(); ++it) {
            if (it->header == header) return *it;
        }
        ADD_FAILURE() << "no section " << header;
        return sections.back();
    }
    // Without `key` in the last `header` section.
    SceneText drop(const std::string& header, const std::string& key) const {
        SceneText t = *this;
        auto& lines = t.last(header).lines;
        for (auto it = lines.begin(); it != lines.end();) {
            it = it->rfind(key + " = ", 0) == 0 ? lines.erase(it) : it + 1;
        }
        return t;
    }
    // With `key = value` in the last `header` section (replacing the key's line).
    SceneText set(const std::string& header, const std::string& key, const std::string& value) const {
        SceneText t = drop(header, key);
        t.last(header).lines.push_back(key + " = " + value);
        return t;
    }
    std::string str() const {
        std::string s;
        for (const auto& sec : sections) {
            s += sec.header + "\n";
            for (const auto& l : sec.lines) s += l + "\n";
        }
        return s;
    }
};

// "[[bodies]].rotation" -> "bodies[0].rotation", as the reader's messages name keys.
std::string path_of(const std::string& table) {
    std::string out = table;
    const std::size_t open = out.find("[[");
    if (open != std::string::npos) {
        const std::size_t close = out.find("]]");
        out = out.substr(open + 2, close - open - 2) + "[0]" + out.substr(close + 2);
    }
    return out;
}

// The TOML header of the section holding `table`'s keys.
std::string header_of(const std::string& table) {
    if (table.rfind("[[", 0) == 0 && table.size() > 2 && table.compare(table.size() - 2, 2, "]]") == 0) return table;
    std::string t = table;
    for (const char* s : {"[[", "]]"}) {
        for (std::size_t p; (p = t.find(s)) != std::string::npos;) t.erase(p, 2);
    }
    return "[" + t + "]";
}

SceneText scene_only() { return SceneText().add("[scene]", {"name = \"keys\""}); }
SceneText with_catoms() { return scene_only().add("[catoms]", {"count = 8"}); }
SceneText two_bodies(const std::string& a, const std::string& b) {
    return scene_only()
        .add("[[bodies]]", {"name = \"" + a + "\"", "position = [0.0, 0.0, 1.0]"})
        .add("[[bodies]]", {"name = \"" + b + "\"", "position = [1.0, 0.0, 1.0]"});
}

// The smallest valid scene holding `table` (its section last).
SceneText base_for(const std::string& table) {
    if (table == "scene") return SceneText().add("[catoms]", {"count = 8"}).add("[scene]", {"name = \"keys\""});
    if (table == "catoms") return with_catoms();
    if (table == "[[materials]]") return with_catoms().add("[[materials]]", {"name = \"m\""});
    if (table == "[[bodies]]") return scene_only().add("[[bodies]]", {"name = \"b\""});
    if (table == "[[bodies]].rotation") {
        return scene_only().add("[[bodies]]", {"name = \"b\""}).add("[bodies.rotation]", {"angle = 0.5"});
    }
    if (table == "[[statics]].rotation") return with_catoms().add("[[statics]]").add("[statics.rotation]", {"angle = 0.5"});
    if (table == "[[joints]]") return two_bodies("a", "b").add("[[joints]]", {"bodies = [\"a\", \"b\"]"});
    if (table == "[[joints]].params") {
        return two_bodies("a", "b").add("[[joints]]", {"bodies = [\"a\", \"b\"]"}).add("[joints.params]");
    }
    if (table == "controller") {
        return two_bodies("chassis", "wheel")
            .add("[[joints]]", {"name = \"w\"", "type = \"hinge2\"", "bodies = [\"chassis\", \"wheel\"]"})
            .add("[controller]", {"drive = [\"w\"]"});
    }
    if (table == "program") return with_catoms().add("[program]", {"name = \"gradient\""});
    if (table == "[[checks.position]]") return with_catoms().add("[[checks.position]]", {"body = 0", "max = 1.0"});
    return with_catoms().add(header_of(table));  // solver, solver.auto_disable, planes, statics, magnets, guard, checks, parallel, run
}

// Other keys a key needs to be read at all (`length` is read for capsules and cylinders only).
const std::map<std::string, std::string> kContext = {
    {"[[bodies]].length", "shape = \"capsule\""}, {"[[bodies]].size", "shape = \"box\""},
    {"[[statics]].length", "shape = \"capsule\""}, {"[[statics]].size", "shape = \"box\""},
};

std::string id(const SceneKey& k) { return k.table.empty() ? k.key : k.table + "." + k.key; }

SceneText base_for_key(const SceneKey& k) {
    SceneText t = base_for(k.table);
    const auto c = kContext.find(id(k));
    if (c != kContext.end()) t.last(header_of(k.table)).lines.push_back(c->second);
    return t;
}

// Keys with a finite bound that the bound test leaves out, and why.
const std::map<std::string, std::string> kBoundSkips = {
    {"catoms.base", "the whole prism must lie within |x| <= 1e6 m (checked on catoms.spacing), so a base at the "
                    "coordinate bound already puts catoms past it: the effective bound depends on count, spacing "
                    "and radius"},
};

bool is_integer(const SceneKey& k) { return k.type == "integer"; }

std::string number_text(double x) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", x);
    return buf;
}

constexpr double kLongMax = static_cast<double>(std::numeric_limits<long>::max());  // 2^63 as a double

// `x` as the key's TOML value: an integer, a number, or a vector with `x` first.
std::string value_text(const SceneKey& k, double x) {
    if (is_integer(k)) {
        if (x >= kLongMax) return x > kLongMax ? "9223372036854775808" : "9223372036854775807";
        return std::to_string(static_cast<long long>(x));
    }
    if (k.type != "[x, y, z]") return number_text(x);
    const bool zero_ok = k.bound == parode::KeyBound::Length || (k.lo <= 0 && 0 <= k.hi);
    const std::string other = zero_ok ? "0.0" : number_text(k.lo);
    return "[" + number_text(x) + ", " + other + ", " + other + "]";
}

// Just past a bound: the next integer, or a millionth of the bound further.
double past(const SceneKey& k, double bound, double direction) {
    if (is_integer(k)) return bound >= kLongMax ? std::nextafter(kLongMax, HUGE_VAL) : bound + direction;
    const double step = bound == 0 ? 1e-6 : std::fabs(bound) * 1e-6;
    return bound + direction * step;
}

// The SceneError of loading `text`, or "" when it loads.
std::string load_error(const std::string& text) {
    try {
        parode::load_scene_text(text, "keys.toml");
    } catch (const parode::SceneError& e) {
        return e.what();
    }
    return "";
}

TEST(SceneKeys, EveryNumericBoundIsTheReaders) {
    int checked = 0;
    std::set<std::string> skipped;
    for (const SceneKey& k : parode::scene_keys()) {
        if (!std::isfinite(k.lo) && !std::isfinite(k.hi)) continue;
        if (kBoundSkips.count(id(k))) {
            skipped.insert(id(k));
            continue;
        }
        SCOPED_TRACE(id(k) + " (range " + k.range + ")");
        const SceneText base = base_for_key(k);
        const std::string header = header_of(k.table);
        const std::string named = "key '" + path_of(k.table) + "." + k.key + "'";
        struct Probe {
            double bound, direction;
            bool inclusive;
        };
        std::vector<Probe> probes;
        if (std::isfinite(k.lo)) probes.push_back({k.lo, -1, k.lo_inclusive});
        if (std::isfinite(k.hi)) probes.push_back({k.hi, +1, k.hi_inclusive});
        for (const Probe& p : probes) {
            const std::string at = value_text(k, p.bound), beyond = value_text(k, past(k, p.bound, p.direction));
            const std::string at_error = load_error(base.set(header, k.key, at).str());
            if (p.inclusive) {
                EXPECT_EQ(at_error, "") << k.key << " = " << at << " should load";
            } else {
                EXPECT_NE(at_error.find(named), std::string::npos) << k.key << " = " << at << ": " << at_error;
            }
            const std::string error = load_error(base.set(header, k.key, beyond).str());
            EXPECT_NE(error.find(named), std::string::npos) << k.key << " = " << beyond << " should fail naming "
                                                            << named << "; got: '" << error << "'";
        }
        ++checked;
    }
    EXPECT_GT(checked, 60);
    std::set<std::string> listed;
    for (const auto& s : kBoundSkips) listed.insert(s.first);
    EXPECT_EQ(skipped, listed) << "kBoundSkips names a key without a finite bound, or one the table lacks";
}

// Written as its default, a key changes nothing: the scene the reader builds
// without it holds the same settings and steps exactly like the one with it.
const std::vector<std::string> kDefaultTables = {"scene", "solver", "catoms", "magnets", "guard", "parallel"};

// Keys of those tables whose default cannot be written as a value, and why.
const std::map<std::string, std::string> kDefaultSkips = {
    {"scene.name", "required: no default"},
    {"scene.description", "never read: no default"},
    {"solver.auto_disable", "a table: absent means off, and writing it at all turns auto-disable on"},
    {"catoms.material", "defaults to the first material: a name that depends on [[materials]]"},
    {"guard.max_energy_gain", "unset by default: the guard then computes its own bound"},
};

// The default as a TOML value: the number, or the text where it is a TOML literal ([0, 0, -9.81], true, "quick").
std::string default_value_text(const SceneKey& k) {
    if (std::isfinite(k.default_value)) {
        return is_integer(k) ? std::to_string(static_cast<long long>(k.default_value)) : number_text(k.default_value);
    }
    if (k.default_text.empty()) return "";
    try {
        std::istringstream in("v = " + k.default_text);
        toml::parse(in, "default");
        return k.default_text;
    } catch (const std::exception&) {
        return "";
    }
}

SceneText magnetic_pile() {
    return scene_only().add("[catoms]", {"count = 27"}).add("[magnets]").add("[solver]").add("[guard]").add("[parallel]").add("[[planes]]");
}

// What the readers of those tables set, including what 5 steps cannot show
// (scene.steps, guard.max_speed, [parallel]).
std::string settings(const std::string& text) {
    const parode::Scene sc = parode::load_scene_text(text, "keys.toml");
    const parode::SolverSpec& s = sc.solver;
    const parode::CatomBlock& c = sc.catoms;
    const parode::MagnetModel& m = sc.magnets;
    std::ostringstream os;
    os.precision(17);
    os << sc.seed << ' ' << sc.steps << ' ' << sc.dt << ' ' << sc.gravity[0] << ' ' << sc.gravity[1] << ' '
       << sc.gravity[2] << ' ' << sc.observe_every << " | " << static_cast<int>(s.stepper) << ' ' << s.iterations << ' '
       << s.sor_w << ' ' << s.erp << ' ' << s.cfm << ' ' << s.contact_surface_layer << ' ' << s.contact_max_correcting_vel
       << ' ' << s.max_contacts << ' ' << s.warm_start << ' ' << s.auto_disable << " | " << c.count << ' '
       << c.proto.shape.radius << ' ' << c.proto.mass << ' ' << c.spacing << ' ' << c.jitter << ' ' << c.base[0] << ' '
       << c.base[1] << ' ' << c.base[2] << ' ' << c.proto.velocity[0] << ' ' << c.proto.material << " | " << m.enabled
       << ' ' << m.directions.size() << ' ' << m.strength << ' ' << m.softening << ' ' << m.cutoff << ' '
       << sc.magnets_off.size() << " | " << sc.guard.energy << ' ' << sc.guard.max_energy_gain.value_or(-1) << ' '
       << sc.guard.max_speed << " | " << sc.parallel.rebalance_threshold << ' ' << sc.parallel.rebalance_every;
    return os.str();
}

std::uint64_t hash_after_5(const std::string& text, const std::string& solver) {
    const parode::Scene sc = parode::load_scene_text(text, "keys.toml");
    return parode::test::run(sc, 5, "grid", 1, solver)->last().state_hash;
}

TEST(SceneKeys, EveryDefaultIsTheReaders) {
    const SceneText base = magnetic_pile();
    int checked = 0;
    std::set<std::string> skipped;
    for (const SceneKey& k : parode::scene_keys()) {
        if (std::find(kDefaultTables.begin(), kDefaultTables.end(), k.table) == kDefaultTables.end()) continue;
        const std::string value = default_value_text(k);
        if (value.empty()) {
            skipped.insert(id(k));
            continue;
        }
        SCOPED_TRACE(id(k) + " = " + value + " (default " + k.default_text + ")");
        const std::string header = header_of(k.table);
        const SceneText without = base.drop(header, k.key);
        const SceneText with = without.set(header, k.key, value);
        EXPECT_EQ(settings(with.str()), settings(without.str()));
        for (const char* solver : {"parallel", "ode"}) {
            EXPECT_EQ(hash_after_5(with.str(), solver), hash_after_5(without.str(), solver)) << "solver " << solver;
        }
        ++checked;
    }
    EXPECT_GT(checked, 25);
    std::set<std::string> listed;
    for (const auto& s : kDefaultSkips) listed.insert(s.first);
    EXPECT_EQ(skipped, listed) << "a key of these tables without a writable default needs a reason in kDefaultSkips";
}

TEST(SceneKeys, AKeyOutsideTheTableIsRefused) {
    for (const std::string& table : parode::scene_tables()) {
        SCOPED_TRACE("table '" + table + "'");
        std::string error;
        if (table.empty()) {
            error = load_error("no_such_key = 1\n" + with_catoms().str());  // before the first header: top level
        } else {
            error = load_error(base_for(table).set(header_of(table), "no_such_key", "1").str());
        }
        const std::string path = table.empty() ? "no_such_key" : path_of(table) + ".no_such_key";
        EXPECT_NE(error.find("'" + path + "'"), std::string::npos) << error;
        if (table == "[[joints]].params") {
            EXPECT_NE(error.find("unknown joint parameter"), std::string::npos) << error;
            continue;
        }
        std::string list;
        for (const std::string& key : parode::table_keys(table)) list += (list.empty() ? "" : ", ") + key;
        EXPECT_NE(error.find("unknown key '" + path + "' (expected one of: " + list + ")"), std::string::npos) << error;
    }
}

TEST(SceneKeys, JointParametersAreTheOdeMapping) {
    std::string names = parode::joint_param_names();
    names = names.substr(0, names.find(" (add"));
    std::set<std::string> mapped;
    for (std::size_t at = 0; at <= names.size();) {
        const std::size_t comma = std::min(names.find(", ", at), names.size());
        mapped.insert(names.substr(at, comma - at));
        at = comma + 2;
    }
    const std::vector<std::string> listed = parode::table_keys("[[joints]].params");
    EXPECT_EQ(mapped, std::set<std::string>(listed.begin(), listed.end()));
    for (const std::string& name : listed) {
        for (const char* suffix : {"", "2", "3"}) EXPECT_GE(parode::joint_param_code(name + suffix), 0) << name << suffix;
    }
}

TEST(SceneKeys, TheTableIsWellFormed) {
    const auto tables = parode::scene_tables();
    ASSERT_FALSE(tables.empty());
    EXPECT_EQ(tables.front(), "");
    std::set<std::string> opened;
    for (const SceneKey& k : parode::scene_keys()) {
        SCOPED_TRACE(id(k));
        EXPECT_FALSE(k.meaning.empty());
        EXPECT_FALSE(k.type.empty());
        if (k.type == "number" || k.type == "integer") {
            EXPECT_FALSE(std::isnan(k.lo) || std::isnan(k.hi)) << "a number's range as numbers";
            EXPECT_FALSE(k.range.empty());
        }
        if (k.type == "table" || k.type == "array of tables") {
            const std::string dotted = k.table.empty() ? k.key : k.table + "." + k.key;
            opened.insert(k.type == "table" ? dotted : "[[" + dotted + "]]");
        }
        const auto keys = parode::table_keys(k.table);
        EXPECT_EQ(std::count(keys.begin(), keys.end(), k.key), 1) << "listed twice";
    }
    std::set<std::string> rest(tables.begin() + 1, tables.end());
    EXPECT_EQ(opened, rest) << "every table but the top level is a key of the table above it";
}

TEST(SceneKeys, TheMarkdownListsEveryKey) {
    const std::string md = parode::scene_keys_markdown();
    for (const SceneKey& k : parode::scene_keys()) {
        if (k.type == "table" || k.type == "array of tables") continue;  // tables are headings (below)
        EXPECT_NE(md.find("`" + k.key + "`"), std::string::npos) << id(k);
    }
    for (const std::string& t : parode::scene_tables()) {
        if (t.empty()) continue;
        const std::string shown = t.rfind("[[", 0) == 0 ? t : "[" + t + "]";
        EXPECT_NE(md.find("`" + shown + "`"), std::string::npos) << t;
    }
}

}  // namespace
