// A registry of named implementations of one stage: name -> factory. The core
// registers its reference implementations; omp/ adds parallel ones at start-up.
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

    void add(const std::string& name, Factory factory) {
        for (auto& e : entries_) {
            if (e.first == name) {
                e.second = std::move(factory);
                return;
            }
        }
        entries_.emplace_back(name, std::move(factory));
    }

    // Throws std::invalid_argument naming the known entries for an unknown name.
    std::unique_ptr<Product> make(const std::string& name, Args... args) const {
        for (const auto& e : entries_) {
            if (e.first == name) return e.second(args...);
        }
        std::string known;
        for (const auto& e : entries_) known += (known.empty() ? "" : ", ") + e.first;
        throw std::invalid_argument("unknown " + what_ + " '" + name + "' (expected one of: " + known + ")");
    }

    std::vector<std::string> names() const {
        std::vector<std::string> out;
        for (const auto& e : entries_) out.push_back(e.first);
        return out;
    }

private:
    std::string what_;
    std::vector<std::pair<std::string, Factory>> entries_;
};

}  // namespace parode
