// Buffers that stages running one after the other lend each other. Each stage
// keeps its large per-call arrays (rebuilt from nothing every call) in slots
// of a ScratchPool; the pipeline gives the collider, the contact solver and
// the distributed domain's ghost exchange one pool, so the collider's geom
// tables, the solver's rows and bodies and the exchange's messages occupy
// the same memory at different times of the step instead of side by side.
// A slot grows by freeing its old buffer before taking a new one (twice what
// is asked, see util/scratch.hpp), 64-byte aligned; capacity not yet touched
// costs no resident memory.
// Trade-off: a slot's contents are undefined after resize and are overwritten
// by the slot's next user, so only arrays whose every element is written after
// sizing, and read only until the stage ends, may live in a pool; a stage
// using two arrays at once uses two slots.
#pragma once
#include <array>
#include <cstddef>
#include <memory>
#include <type_traits>

#include "util/huge_pages.hpp"

namespace parode {

class ScratchPool {
public:
    static constexpr int kSlots = 5;
    // At least `bytes` bytes of slot `slot`, 64-byte aligned; contents undefined.
    void* take(int slot, std::size_t bytes) {
        Slot& s = slots_[static_cast<std::size_t>(slot)];
        if (bytes > s.capacity) {
            s.data.reset();
            s.capacity = 2 * bytes;
            s.data.reset(new std::byte[s.capacity + 63]);
            advise_huge_pages(s.data.get(), s.capacity + 63);
        }
        const auto at = reinterpret_cast<std::uintptr_t>(s.data.get());
        return s.data.get() + ((64 - at % 64) % 64);
    }

private:
    struct Slot {
        std::unique_ptr<std::byte[]> data;
        std::size_t capacity = 0;
    };
    std::array<Slot, kSlots> slots_;
};

// An array of trivial T in a pool slot, with the vector operations its users
// need. resize() leaves the elements undefined.
template <class T>
class ScratchArray {
    static_assert(std::is_trivially_copyable_v<T> && std::is_trivially_destructible_v<T>, "plain data only");

public:
    ScratchArray(ScratchPool* pool, int slot) : pool_(pool), slot_(slot) {}
    ScratchArray(const ScratchArray&) = delete;
    ScratchArray& operator=(const ScratchArray&) = delete;
    void set_pool(ScratchPool* pool) {
        pool_ = pool;
        data_ = nullptr;
        size_ = 0;
    }
    void resize(std::size_t n) {
        data_ = n ? static_cast<T*>(pool_->take(slot_, n * sizeof(T))) : nullptr;
        size_ = n;
    }
    std::size_t size() const { return size_; }
    bool empty() const { return size_ == 0; }
    T* data() { return data_; }
    const T* data() const { return data_; }
    T& operator[](std::size_t i) { return data_[i]; }
    const T& operator[](std::size_t i) const { return data_[i]; }
    T* begin() { return data_; }
    T* end() { return data_ + size_; }
    const T* begin() const { return data_; }
    const T* end() const { return data_ + size_; }

private:
    ScratchPool* pool_;
    int slot_;
    T* data_ = nullptr;
    std::size_t size_ = 0;
};

// The slots of the users the pipeline pairs: the collider, the contact
// solver and, between steps, the distributed domain's ghost exchange.
enum ScratchSlot : int { kSlotGeoms = 0, kSlotEntries = 1, kSlotPrims = 2 };  // collider
enum SolverSlot : int { kSlotRows = 0, kSlotBodies = 1, kSlotBodyRows = 2, kSlotMotion = 3, kSlotReach = 4 };  // contact solver (motion, reach: substeps)
enum ExchangeSlot : int { kSlotMessages = 0 };  // ghost exchange: its messages out and in

}  // namespace parode
