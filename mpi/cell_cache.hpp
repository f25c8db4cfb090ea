// CellCache: what CellMap has worked out about the cells this process meets,
// a 32-bit value per 64-bit cell key, in one open-addressing table (keys and
// values in two arrays, linear probing, at most three quarters full, a power
// of two slots). Entries are only added, and all dropped together (a new
// partition). A cell costs 16 to 32 bytes here; in a node-based hash map
// (a 24-byte node, its allocation's header and a bucket) about 40.
// Trade-off: no deletion, and a table that grows copies every entry (the
// cells met grow with the bodies held, not with the steps).
#pragma once
#include <cstdint>
#include <vector>

namespace parode::mpi {

class CellCache {
public:
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
    static constexpr std::uint64_t kEmpty = ~0ULL;  // no cell key (CellSpace keys use 60 bits)

    // The value of `key`, or kNone.
    std::uint32_t find(std::uint64_t key) const {
        if (keys_.empty()) return kNone;
        for (std::size_t i = home(key);; i = (i + 1) & mask_) {
            if (keys_[i] == key) return values_[i];
            if (keys_[i] == kEmpty) return kNone;
        }
    }
    // Adds `key` (not yet present) with `value`.
    void add(std::uint64_t key, std::uint32_t value) {
        if (4 * (count_ + 1) > 3 * keys_.size()) grow();
        place(key, value);
        ++count_;
    }
    void clear() {
        keys_.clear();
        keys_.shrink_to_fit();
        values_.clear();
        values_.shrink_to_fit();
        count_ = 0;
    }
    std::size_t size() const { return count_; }

private:
    std::size_t home(std::uint64_t key) const { return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ULL) >> shift_); }
    void place(std::uint64_t key, std::uint32_t value) {
        std::size_t i = home(key);
        while (keys_[i] != kEmpty) i = (i + 1) & mask_;
        keys_[i] = key;
        values_[i] = value;
    }
    void grow() {
        const std::size_t slots = keys_.empty() ? 64 : 2 * keys_.size();
        std::vector<std::uint64_t> keys(slots, kEmpty);
        std::vector<std::uint32_t> values(slots, kNone);
        keys.swap(keys_);
        values.swap(values_);
        mask_ = slots - 1;
        shift_ = 64;
        for (std::size_t s = slots; s > 1; s >>= 1) --shift_;
        for (std::size_t i = 0; i < keys.size(); ++i) {
            if (keys[i] != kEmpty) place(keys[i], values[i]);
        }
    }

    std::vector<std::uint64_t> keys_;
    std::vector<std::uint32_t> values_;
    std::size_t count_ = 0, mask_ = 0;
    int shift_ = 64;
};

}  // namespace parode::mpi
