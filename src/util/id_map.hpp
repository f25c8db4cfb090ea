// IdMap: global body id -> local storage index. A dense table when the ids
// held are most of the global range (one process holding a whole scene, or
// one of two: every lookup one load), an open-addressing hash table
// otherwise: 8 bytes a slot (id and index in one word), at most half full,
// linear probing, deletion by shifting the run back (no tombstones). A rank
// pays 16 to 32 bytes for each body it holds, whatever the machine's size:
// a dense table sized by the scene cost 4 bytes per body of the whole scene
// (32 a held body on 8 ranks), and std::unordered_map about 40 a held body.
// Trade-off: the choice is made once per reset(); a process whose share
// shrinks keeps the dense table until the next reset. A lookup in the hash
// costs a multiplication and, mostly, one load more than the dense table's.
#pragma once
#include <cstdint>
#include <vector>

namespace parode {

class IdMap {
public:
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;

    // `global` ids in all, about `expected` of them held here.
    void reset(std::size_t global, std::size_t expected) {
        dense_ = global <= 2 * expected + 4096;
        table_.assign(dense_ ? global : 0, kNone);
        count_ = 0;
        slots_.clear();
        if (!dense_) rehash(expected);
    }
    void set(std::uint32_t id, std::uint32_t local) {
        if (dense_) {
            table_[id] = local;
            return;
        }
        if (2 * (count_ + 1) > slots_.size()) rehash(count_ + 1 + count_ / 4);
        std::size_t i = home(id);
        for (; slots_[i] != kEmpty; i = (i + 1) & mask_) {
            if (key(slots_[i]) == id) break;
        }
        if (slots_[i] == kEmpty) ++count_;
        slots_[i] = pack(id, local);
    }
    void erase(std::uint32_t id) {
        if (dense_) {
            table_[id] = kNone;
            return;
        }
        std::size_t i = slot_of(id);
        if (i == kNowhere) return;
        --count_;
        // Shift back the entries after i whose home is not in (i, j].
        for (std::size_t j = (i + 1) & mask_; slots_[j] != kEmpty; j = (j + 1) & mask_) {
            const std::size_t h = home(key(slots_[j]));
            const bool stays = i <= j ? (i < h && h <= j) : (i < h || h <= j);
            if (stays) continue;
            slots_[i] = slots_[j];
            i = j;
        }
        slots_[i] = kEmpty;
    }
    std::uint32_t find(std::uint32_t id) const {
        if (dense_) return id < table_.size() ? table_[id] : kNone;
        const std::size_t i = slot_of(id);
        return i == kNowhere ? kNone : static_cast<std::uint32_t>(slots_[i]);
    }
    bool dense() const { return dense_; }

private:
    static constexpr std::uint64_t kEmpty = ~0ULL;
    static constexpr std::size_t kNowhere = ~std::size_t{0};
    static std::uint64_t pack(std::uint32_t id, std::uint32_t local) { return (std::uint64_t{id} << 32) | local; }
    static std::uint32_t key(std::uint64_t slot) { return static_cast<std::uint32_t>(slot >> 32); }
    std::size_t home(std::uint32_t id) const {
        return static_cast<std::size_t>((std::uint64_t{id} * 0x9E3779B97F4A7C15ULL) >> shift_);
    }
    std::size_t slot_of(std::uint32_t id) const {
        for (std::size_t i = home(id); slots_[i] != kEmpty; i = (i + 1) & mask_) {
            if (key(slots_[i]) == id) return i;
        }
        return kNowhere;
    }
    // Room for `n` entries at most half full (a power of two slots), every
    // entry placed again.
    void rehash(std::size_t n) {
        int bits = 4;
        while ((std::size_t{1} << bits) < 2 * n) ++bits;
        std::vector<std::uint64_t> old(std::size_t{1} << bits, kEmpty);
        old.swap(slots_);
        mask_ = slots_.size() - 1;
        shift_ = 64 - bits;
        for (std::uint64_t s : old) {
            if (s == kEmpty) continue;
            std::size_t i = home(key(s));
            while (slots_[i] != kEmpty) i = (i + 1) & mask_;
            slots_[i] = s;
        }
    }

    bool dense_ = true;
    std::vector<std::uint32_t> table_;
    std::vector<std::uint64_t> slots_;
    std::size_t mask_ = 0, count_ = 0;
    int shift_ = 64;
};

}  // namespace parode
