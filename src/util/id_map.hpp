// IdMap: global body id -> local storage index. A dense table when the ids
// held are a sizeable part of the global range (one process holding a whole
// scene: every lookup one load), a hash table otherwise (a rank holding a
// few thousand of a hundred million ids: memory in what it holds).
// Trade-off: the choice is made once per reset(); a process whose share
// shrinks keeps the dense table until the next reset.
#pragma once
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace parode {

class IdMap {
public:
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;

    // `global` ids in all, about `expected` of them held here.
    void reset(std::size_t global, std::size_t expected) {
        dense_ = global <= 16 * expected + 4096;
        table_.assign(dense_ ? global : 0, kNone);
        hash_.clear();
        if (!dense_) hash_.reserve(expected);
    }
    void set(std::uint32_t id, std::uint32_t local) {
        if (dense_) table_[id] = local;
        else hash_[id] = local;
    }
    void erase(std::uint32_t id) {
        if (dense_) table_[id] = kNone;
        else hash_.erase(id);
    }
    std::uint32_t find(std::uint32_t id) const {
        if (dense_) return id < table_.size() ? table_[id] : kNone;
        const auto it = hash_.find(id);
        return it == hash_.end() ? kNone : it->second;
    }

private:
    bool dense_ = true;
    std::vector<std::uint32_t> table_;
    std::unordered_map<std::uint32_t, std::uint32_t> hash_;
};

}  // namespace parode
