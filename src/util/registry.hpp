// A registry of named implementations of one stage: name -> factory, with
// aliases (older names that keep working) and a line saying what each is.
// A threaded variant of a serial implementation X is named X/omp (LAMMPS's
// suffix styles), so that the relation shows in every listing.
// Trade-off: a linear list (a handful of entries) keeps registration order,
// which is the order `--help` lists them in.
#pragma once
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace parode {

template <class Product, class... Args>
class Registry {
public:
    using Factory = std::function<std::unique_ptr<Product>(Args...)>;

    explicit Registry(std::string what) : what_(std::move(what)) {}

    // Adds (or replaces) `name`; `aliases` name it too.
    void add(const std::string& name, Factory factory, std::vector<std::string> aliases = {}, std::string about = {}) {
        for (auto& e : entries_) {
            if (e.name == name) {
                e.factory = std::move(factory);
                e.aliases = std::move(aliases);
                e.about = std::move(about);
                return;
            }
        }
        entries_.push_back({name, std::move(factory), std::move(aliases), std::move(about)});
    }

    bool has(const std::string& name) const { return find(name) != nullptr; }
    // The registered name that `name` (a name or an alias) stands for; throws
    // std::invalid_argument naming the known entries for an unknown name.
    const std::string& canonical(const std::string& name) const { return entry(name).name; }

    std::unique_ptr<Product> make(const std::string& name, Args... args) const { return entry(name).factory(args...); }

    // Registered names, in registration order.
    std::vector<std::string> names() const {
        std::vector<std::string> out;
        for (const auto& e : entries_) out.push_back(e.name);
        return out;
    }
    // Names and aliases: everything `make` accepts.
    std::vector<std::string> accepted() const {
        std::vector<std::string> out;
        for (const auto& e : entries_) {
            out.push_back(e.name);
            out.insert(out.end(), e.aliases.begin(), e.aliases.end());
        }
        return out;
    }
    // "a, b (also c), d": for help texts and error messages.
    std::string listing() const {
        std::string out;
        for (const auto& e : entries_) {
            out += (out.empty() ? "" : ", ") + e.name;
            if (!e.aliases.empty()) {
                std::string also;
                for (const auto& a : e.aliases) also += (also.empty() ? "" : ", ") + a;
                out += " (also " + also + ")";
            }
        }
        return out;
    }
    const std::string& about(const std::string& name) const { return entry(name).about; }

private:
    struct Entry {
        std::string name;
        Factory factory;
        std::vector<std::string> aliases;
        std::string about;
    };
    const Entry* find(const std::string& name) const {
        for (const auto& e : entries_) {
            if (e.name == name) return &e;
            for (const auto& a : e.aliases) {
                if (a == name) return &e;
            }
        }
        return nullptr;
    }
    const Entry& entry(const std::string& name) const {
        if (const Entry* e = find(name)) return *e;
        throw std::invalid_argument("unknown " + what_ + " '" + name + "' (expected one of: " + listing() + ")");
    }

    std::string what_;
    std::vector<Entry> entries_;
};

}  // namespace parode
