// IdMap: global body id -> local storage index. A dense table when the ids
// held are most of the global range (one process holding a whole scene, or
// one of two: every lookup one load); otherwise the same table in pages of
// 16 consecutive ids (a cache line of indices), found by page number in an
// open-addressing hash (8 bytes a slot, at most half full, linear probing,
// deletion by shifting the run back, no tombstones); a page is given back
// when its last id leaves. A rank's ids come in runs (a row of catoms in its
// blocks: 100 long at 10^6 catoms a rank on 8 ranks), so a held body costs
// about 4.5 bytes of pages and 2 of directory: 6.6 MB for a million, where a
// hash of ids cost 16.8 MB and the dense table 4 bytes per body of the whole
// scene (32 MB a rank on 8 ranks of 10^6).
// Trade-off: the choice is made once per reset(); a process whose share
// shrinks keeps the dense table until the next reset. A paged lookup costs a
// multiplication and two dependent loads where the dense table's costs one;
// ids scattered one per page (a sparse share) would cost 64 bytes each.
#pragma once
#include <cstdint>
#include <vector>

namespace parode {

// Open-addressing hash from a 32-bit key to a 32-bit value (IdMap's pages).
class IdDirectory {
public:
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;

    void reset(std::size_t expected) {
        count_ = 0;
        slots_.clear();
        rehash(expected);
    }
    void set(std::uint32_t key, std::uint32_t value) {
        if (2 * (count_ + 1) > slots_.size()) rehash(count_ + 1 + count_ / 4);
        std::size_t i = home(key);
        for (; slots_[i] != kEmpty; i = (i + 1) & mask_) {
            if (key_of(slots_[i]) == key) break;
        }
        if (slots_[i] == kEmpty) ++count_;
        slots_[i] = pack(key, value);
    }
    void erase(std::uint32_t key) {
        std::size_t i = slot_of(key);
        if (i == kNowhere) return;
        --count_;
        // Shift back the entries after i whose home is not in (i, j].
        for (std::size_t j = (i + 1) & mask_; slots_[j] != kEmpty; j = (j + 1) & mask_) {
            const std::size_t h = home(key_of(slots_[j]));
            const bool stays = i <= j ? (i < h && h <= j) : (i < h || h <= j);
            if (stays) continue;
            slots_[i] = slots_[j];
            i = j;
        }
        slots_[i] = kEmpty;
    }
    std::uint32_t find(std::uint32_t key) const {
        const std::size_t i = slot_of(key);
        return i == kNowhere ? kNone : static_cast<std::uint32_t>(slots_[i]);
    }

private:
    static constexpr std::uint64_t kEmpty = ~0ULL;
    static constexpr std::size_t kNowhere = ~std::size_t{0};
    static std::uint64_t pack(std::uint32_t key, std::uint32_t value) { return (std::uint64_t{key} << 32) | value; }
    static std::uint32_t key_of(std::uint64_t slot) { return static_cast<std::uint32_t>(slot >> 32); }
    std::size_t home(std::uint32_t key) const {
        return static_cast<std::size_t>((std::uint64_t{key} * 0x9E3779B97F4A7C15ULL) >> shift_);
    }
    std::size_t slot_of(std::uint32_t key) const {
        for (std::size_t i = home(key); slots_[i] != kEmpty; i = (i + 1) & mask_) {
            if (key_of(slots_[i]) == key) return i;
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
            std::size_t i = home(key_of(s));
            while (slots_[i] != kEmpty) i = (i + 1) & mask_;
            slots_[i] = s;
        }
    }

    std::vector<std::uint64_t> slots_;
    std::size_t mask_ = 0, count_ = 0;
    int shift_ = 64;
};

class IdMap {
public:
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
    static constexpr std::uint32_t kPageBits = 4, kPage = 1u << kPageBits, kInPage = kPage - 1;

    // `global` ids in all, about `expected` of them held here.
    void reset(std::size_t global, std::size_t expected) {
        dense_ = global <= 2 * expected + 4096;
        table_.assign(dense_ ? global : 0, kNone);
        used_.clear();
        free_.clear();
        if (dense_) return;
        const std::size_t pages = expected / kPage + expected / (4 * kPage) + 1;  // runs: ~1.1 pages a 16 ids
        table_.reserve(pages * kPage);
        used_.reserve(pages);
        dir_.reset(pages);
    }
    void set(std::uint32_t id, std::uint32_t local) {
        if (dense_) {
            table_[id] = local;
            return;
        }
        std::uint32_t page = dir_.find(id >> kPageBits);
        if (page == kNone) page = new_page(id >> kPageBits);
        std::uint32_t& cell = table_[in_page(page, id)];
        if (cell == kNone) ++used_[page];
        cell = local;
    }
    void erase(std::uint32_t id) {
        if (dense_) {
            table_[id] = kNone;
            return;
        }
        const std::uint32_t page = dir_.find(id >> kPageBits);
        if (page == kNone) return;
        std::uint32_t& cell = table_[in_page(page, id)];
        if (cell == kNone) return;
        cell = kNone;
        if (--used_[page] > 0) return;
        dir_.erase(id >> kPageBits);
        free_.push_back(page);
    }
    std::uint32_t find(std::uint32_t id) const {
        if (dense_) return id < table_.size() ? table_[id] : kNone;
        const std::uint32_t page = dir_.find(id >> kPageBits);
        return page == kNone ? kNone : table_[in_page(page, id)];
    }
    bool dense() const { return dense_; }
    // Pages in use (paged form; 0 when dense).
    std::size_t pages() const { return used_.size() - free_.size(); }

private:
    // Where id's index lies in the table, its page being `page`.
    static std::size_t in_page(std::uint32_t page, std::uint32_t id) { return std::size_t{page} * kPage + (id & kInPage); }
    std::uint32_t new_page(std::uint32_t number) {
        std::uint32_t page;
        if (!free_.empty()) {
            page = free_.back();
            free_.pop_back();
        } else {
            page = static_cast<std::uint32_t>(used_.size());
            used_.push_back(0);
            table_.resize(table_.size() + kPage, kNone);
        }
        dir_.set(number, page);
        return page;
    }

    bool dense_ = true;
    std::vector<std::uint32_t> table_;  // dense: per id; paged: kPage per page
    std::vector<std::uint8_t> used_;    // paged: ids held per page
    std::vector<std::uint32_t> free_;   // paged: pages given back, reused first
    IdDirectory dir_;                   // paged: page number -> page
};

}  // namespace parode
