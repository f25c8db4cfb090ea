// GidTable<T>: objects a process holds, found by global id: an IdMap from
// the id to a slot of a vector of owned pointers, freed slots reused.
// Trade-off: 16 bytes an object on one process (the dense map's 4 a global
// id, the pointer, the slot's id) and 20 to 36 on many (the map's hash),
// against about 40 for std::unordered_map's node and bucket; the slots are
// never shrunk, and the map is sized once per reset() (rebuild() sizes it
// again for what is held then).
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "util/id_map.hpp"

namespace parode {

template <class T>
class GidTable {
public:
    // `gids` global ids in all, about `expected` of them held here.
    void reset(std::size_t gids, std::size_t expected) {
        at_.reset(gids, expected);
        items_.clear();
        ids_.clear();
        free_.clear();
        ready_ = true;
    }
    bool ready() const { return ready_; }
    T* find(std::uint32_t id) const {
        const std::uint32_t s = at_.find(id);
        return s == IdMap::kNone ? nullptr : items_[s].get();
    }
    // The pointer held for `id` (empty when new); valid until the next add.
    std::unique_ptr<T>& at(std::uint32_t id) {
        std::uint32_t s = at_.find(id);
        if (s == IdMap::kNone) {
            if (free_.empty()) {
                s = static_cast<std::uint32_t>(items_.size());
                items_.emplace_back();
                ids_.push_back(id);
            } else {
                s = free_.back();
                free_.pop_back();
                ids_[s] = id;
            }
            at_.set(id, s);
        }
        return items_[s];
    }
    void erase(std::uint32_t id) {
        const std::uint32_t s = at_.find(id);
        if (s == IdMap::kNone) return;
        items_[s].reset();
        free_.push_back(s);
        at_.erase(id);
    }
    // Calls f(id, object) for every object held, in slot order.
    template <class F>
    void each(F f) const {
        for (std::size_t s = 0; s < items_.size(); ++s) {
            if (items_[s]) f(ids_[s], *items_[s]);
        }
    }
    // Keeps only the objects whose id `keep` accepts, in a map sized for them.
    template <class Keep>
    void keep_only(std::size_t gids, Keep keep) {
        std::vector<std::uint32_t> ids;
        std::vector<std::unique_ptr<T>> items;
        for (std::size_t s = 0; s < items_.size(); ++s) {
            if (items_[s] && keep(ids_[s])) ids.push_back(ids_[s]), items.push_back(std::move(items_[s]));
        }
        reset(gids, ids.size());
        for (std::size_t i = 0; i < ids.size(); ++i) at(ids[i]) = std::move(items[i]);
    }

private:
    IdMap at_;
    std::vector<std::unique_ptr<T>> items_;
    std::vector<std::uint32_t> ids_, free_;
    bool ready_ = false;
};

}  // namespace parode
