// Validating TOML reader (see toml_reader.hpp).
#include "scene/toml_reader.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace parode {

std::string where(const toml::value& v) {
    const toml::source_location loc = v.location();
    // A `--set` value has no line of its own: its origin names it fully.
    if (loc.line() == 0 || loc.file_name().rfind("--set ", 0) == 0) return loc.file_name();
    return loc.file_name() + ":" + std::to_string(loc.line());
}

std::string describe(const toml::value& v) {
    switch (v.type()) {
        case toml::value_t::table: return "a table";
        case toml::value_t::array: {
            const std::size_t n = v.as_array().size();
            std::string s = "an array of " + std::to_string(n) + (n == 1 ? " element" : " elements");
            if (n == 0 || n > 4) return s;
            for (std::size_t i = 0; i < n; ++i) {
                const toml::value& e = v.as_array()[i];
                const bool scalar = e.is_integer() || e.is_floating() || e.is_boolean();
                const std::string text = e.is_string() ? "\"" + e.as_string().str + "\"" : scalar ? describe(e) : "...";
                s += (i ? ", " : " [") + text;
            }
            return s + "]";
        }
        case toml::value_t::string: return "the string \"" + v.as_string().str + "\"";
        case toml::value_t::boolean: return v.as_boolean() ? "true" : "false";
        default: {
            std::ostringstream os;
            os << v;
            return os.str();
        }
    }
}

std::string Node::key_path(const std::string& key) const {
    return path_.empty() ? key : path_ + "." + key;
}

bool Node::has(const std::string& key) const {
    return v_->is_table() && v_->as_table().count(key) != 0;
}

Node Node::at(const std::string& key) const {
    require_table();
    if (!has(key)) fail_here("missing required key '" + key_path(key) + "'");
    return Node(v_->as_table().at(key), key_path(key));
}

Node Node::index(std::size_t i) const {
    return Node(v_->as_array().at(i), path_ + "[" + std::to_string(i) + "]");
}

void Node::require_table() const {
    if (!v_->is_table()) fail_here("key '" + path_ + "': expected a table, got " + describe(*v_));
}

std::size_t Node::array_size() const {
    if (!v_->is_array()) fail_here("key '" + path_ + "': expected an array, got " + describe(*v_));
    return v_->as_array().size();
}

void Node::expect_keys(const std::vector<std::string>& allowed) const {
    require_table();
    for (const auto& kv : v_->as_table()) {
        if (std::find(allowed.begin(), allowed.end(), kv.first) != allowed.end()) continue;
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        throw SceneError(where(kv.second) + ": unknown key '" + key_path(kv.first) +
                         "' (expected one of: " + list + ")");
    }
}

void Node::fail(const std::string& key, const std::string& expected) const {
    const toml::value& v = has(key) ? v_->as_table().at(key) : *v_;
    std::string got = has(key) ? ", got " + describe(v) : "";
    throw SceneError(where(v) + ": key '" + key_path(key) + "': expected " + expected + got);
}

void Node::fail_here(const std::string& message) const {
    throw SceneError(where(*v_) + ": " + message);
}

// The literal as written ("1e309"), when toml11 kept the value's location.
static std::string literal_text(const toml::value& v) {
    const toml::source_location loc = v.location();
    const std::string& line = loc.line_str();
    if (loc.column() == 0 || loc.column() - 1 + loc.region() > line.size()) return "";
    std::string s = line.substr(loc.column() - 1, loc.region());
    s.erase(std::remove(s.begin(), s.end(), '_'), s.end());
    return s;
}

// toml11 reads a decimal literal beyond the range of its type as the largest
// value (1e309 -> 1.8e308, 99999999999999999999 -> 2^63 - 1) or as 0 (1e-400),
// without an error: such a literal is reported here instead of being used.
static std::string out_of_range_literal(const toml::value& v) {
    const std::string s = literal_text(v);
    if (s.empty() || s.find_first_of("xobin") != std::string::npos) return "";  // hex/octal/binary, inf, nan
    errno = 0;
    if (v.is_floating()) {
        const double x = std::strtod(s.c_str(), nullptr);
        if (errno == ERANGE) return s + (std::fabs(x) > 1 ? " (beyond the range of a double)" : " (too small for a double)");
    } else if (v.is_integer()) {
        std::strtoll(s.c_str(), nullptr, 10);
        if (errno == ERANGE) return s + " (beyond the range of a 64-bit integer)";
    }
    return "";
}

static void check_literal(const toml::value& v, const std::string& path, const std::string& what) {
    const std::string bad = out_of_range_literal(v);
    if (!bad.empty()) throw SceneError(where(v) + ": key '" + path + "': expected " + what + ", got " + bad);
}

double Node::to_number(const Node& n, const std::string& what) const {
    const toml::value& v = n.value();
    double x = 0;
    if (v.is_integer()) x = static_cast<double>(v.as_integer());
    else if (v.is_floating()) x = v.as_floating();
    else throw SceneError(where(v) + ": key '" + n.path() + "': expected " + what + ", got " + describe(v));
    check_literal(v, n.path(), what);
    if (!std::isfinite(x)) throw SceneError(where(v) + ": key '" + n.path() + "': expected " + what + ", got " + describe(v));
    return x;
}

static std::string range_text(double lo, double hi) {
    std::ostringstream os;
    os << "a number";
    if (std::isfinite(lo) && std::isfinite(hi)) os << " in [" << lo << ", " << hi << "]";
    else if (std::isfinite(lo)) os << " >= " << lo;
    else if (std::isfinite(hi)) os << " <= " << hi;
    return os.str();
}

double Node::number_required(const std::string& key, double lo, double hi) const {
    const std::string what = range_text(lo, hi);
    const double x = to_number(at(key), what);
    if (x < lo || x > hi) fail(key, what);
    return x;
}

double Node::number(const std::string& key, double def, double lo, double hi) const {
    return has(key) ? number_required(key, lo, hi) : def;
}

long Node::integer(const std::string& key, long def, long lo, long hi) const {
    if (!has(key)) return def;
    const toml::value& v = v_->as_table().at(key);
    const std::string what = "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    if (v.is_integer()) check_literal(v, key_path(key), what);
    if (!v.is_integer() || v.as_integer() < lo || v.as_integer() > hi) fail(key, what);
    return static_cast<long>(v.as_integer());
}

bool Node::boolean(const std::string& key, bool def) const {
    if (!has(key)) return def;
    const toml::value& v = v_->as_table().at(key);
    if (!v.is_boolean()) fail(key, "true or false");
    return v.as_boolean();
}

std::string Node::string(const std::string& key, const std::string& def) const {
    if (!has(key)) return def;
    const toml::value& v = v_->as_table().at(key);
    if (!v.is_string()) fail(key, "a string");
    return v.as_string().str;
}

std::string Node::choice(const std::string& key, const std::string& def,
                         std::initializer_list<const char*> options) const {
    const std::string s = string(key, def);
    std::string list;
    for (const char* o : options) {
        if (s == o) return s;
        list += (list.empty() ? "" : ", ") + std::string("\"") + o + "\"";
    }
    fail(key, "one of " + list);
}

Vec3 Node::vec3(const std::string& key, const Vec3& def) const {
    if (!has(key)) return def;
    const Node a = at(key);
    if (!a.value().is_array() || a.value().as_array().size() != 3) fail(key, "an array of 3 numbers");
    Vec3 out{};
    for (std::size_t i = 0; i < 3; ++i) out[i] = to_number(a.index(i), "a number");
    return out;
}

static std::string vec_text(const Vec3& v) {
    std::ostringstream os;
    os << "[" << v[0] << ", " << v[1] << ", " << v[2] << "]";
    return os.str();
}

Vec3 Node::vec3(const std::string& key, const Vec3& def, double bound, const std::string& what) const {
    const Vec3 v = vec3(key, def);
    for (double c : v) if (std::fabs(c) > bound) fail_value(key, what, vec_text(v));
    return v;
}

Vec3 Node::vec3_length(const std::string& key, const Vec3& def, double max_length, const std::string& what) const {
    const Vec3 v = vec3(key, def);
    const double n = std::hypot(v[0], v[1], v[2]);
    if (n > max_length) fail_value(key, what, vec_text(v));
    return v;
}

void Node::fail_value(const std::string& key, const std::string& expected, const std::string& got) const {
    const toml::value& v = has(key) ? v_->as_table().at(key) : *v_;
    throw SceneError(where(v) + ": key '" + key_path(key) + "': expected " + expected + ", got " + got);
}

// "file:line: TOML syntax error:" and toml11's own excerpt of the file.
static std::string syntax_error_text(const std::string& name, const toml::syntax_error& e) {
    const std::size_t line = e.location().line();
    const std::string at = line == 0 ? name : name + ":" + std::to_string(line);
    return at + ": TOML syntax error:\n" + e.what();
}

toml::value parse_toml_file(const std::string& path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw SceneError(path + ": cannot open scene file (it is a directory)");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw SceneError(path + ": cannot open scene file (" + std::strerror(errno) + ")");
    try {
        return toml::parse(in, path);
    } catch (const toml::syntax_error& e) {
        throw SceneError(syntax_error_text(path, e));
    }
}

static std::vector<std::string> split_dots(const std::string& key) {
    std::vector<std::string> parts;
    std::string cur;
    for (char c : key) {
        if (c == '.') {
            parts.push_back(cur);
            cur.clear();
        } else {
            cur += c;
        }
    }
    parts.push_back(cur);
    return parts;
}

static toml::value parse_override_value(const std::string& rhs, const std::string& origin) {
    try {
        std::istringstream in("v = " + rhs);
        return toml::find(toml::parse(in, origin), "v");
    } catch (const std::exception&) {
        if (rhs.find_first_of("\"\\\n") != std::string::npos) {
            throw SceneError(origin + ": the value is not valid TOML (quote strings: key=\"text\")");
        }
        std::istringstream in("v = \"" + rhs + "\"");  // a bare word is a string
        return toml::find(toml::parse(in, origin), "v");
    }
}

// The element of an array named by a `--set` key segment ("bodies.0.mass").
static toml::value& override_element(toml::value& arr, const std::string& seg, const std::string& origin) {
    const bool digits = seg.size() <= 18 && seg.find_first_not_of("0123456789") == std::string::npos;
    if (!digits) throw SceneError(origin + ": '" + seg + "' is not an array index");
    const std::size_t k = std::stoul(seg);
    if (k >= arr.as_array().size()) {
        throw SceneError(origin + ": index " + seg + " out of range (the array has " +
                         std::to_string(arr.as_array().size()) + " elements)");
    }
    return arr.as_array()[k];
}

void apply_override(toml::value& root, const std::string& assignment) {
    const auto eq = assignment.find('=');
    const std::string origin = "--set " + assignment;
    if (eq == std::string::npos || eq == 0) {
        throw SceneError(origin + ": expected key=value (for example catoms.count=8000)");
    }
    const std::vector<std::string> parts = split_dots(assignment.substr(0, eq));
    for (const auto& p : parts) if (p.empty()) throw SceneError(origin + ": empty key segment");
    toml::value* cur = &root;
    for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
        if (cur->is_array()) {
            cur = &override_element(*cur, parts[i], origin);
            continue;
        }
        if (!cur->is_table()) throw SceneError(origin + ": '" + parts[i] + "' is not a table");
        toml::value& next = cur->as_table()[parts[i]];
        if (next.is_uninitialized()) next = parse_override_value("{}", origin);  // errors name the --set
        cur = &next;
    }
    if (!cur->is_table()) throw SceneError(origin + ": the parent of '" + parts.back() + "' is not a table");
    cur->as_table()[parts.back()] = parse_override_value(assignment.substr(eq + 1), origin);
}

}  // namespace parode
