// The catom programs' state between processes and in checkpoints (see
// program_pass.hpp): a catom's record travels to its new owner when it
// migrates; each step's mail goes to the receivers' owners, magnet switches
// and failures to every process; checkpoints hold every catom's record in
// catom order whatever the number of processes, gathered on the process
// that writes them.
// Trade-off: one sparse exchange for the migrants and one for the mail a
// step (messages only to the processes that get something, then a
// non-blocking barrier: no count from every process, so it scales with the
// neighbours, not the machine), kept apart from the ghost exchange, which
// runs before the handlers have sent anything; switches go to every process,
// which costs little while programs switch rarely and keeps every ghost's
// magnets right wherever it appears.
#include <algorithm>
#include <cstring>
#include <iterator>

#include "programs/catom_state.hpp"
#include "programs/program_pass.hpp"
#include "util/errors.hpp"
#include "util/id_map.hpp"

namespace parode {
namespace {

// Plain values appended to and read from a byte buffer.
// Bytes ran past the end of what it reads: a window of a checkpoint's
// section to refill, or a section or message that is cut short.
struct CutShort : CheckpointError {
    CutShort() : CheckpointError("the catom programs' state in the checkpoint is cut short") {}
};

class Bytes {
public:
    explicit Bytes(std::vector<char>& out) : out_(&out) {}
    Bytes(const std::vector<char>& in, std::size_t at) : in_(&in), at_(at) {}
    template <class T>
    void put(const T& v) {
        const char* p = reinterpret_cast<const char*>(&v);
        out_->insert(out_->end(), p, p + sizeof v);
    }
    void put_bytes(const void* p, std::size_t n) {
        put(static_cast<std::uint64_t>(n));
        const char* c = static_cast<const char*>(p);
        out_->insert(out_->end(), c, c + n);
    }
    template <class T>
    T get() {
        need(sizeof(T));
        T v;
        std::memcpy(&v, in_->data() + at_, sizeof v);
        at_ += sizeof v;
        return v;
    }
    std::vector<unsigned char> get_bytes() {
        const auto n = static_cast<std::size_t>(get<std::uint64_t>());
        need(n);
        std::vector<unsigned char> v(in_->begin() + static_cast<std::ptrdiff_t>(at_),
                                     in_->begin() + static_cast<std::ptrdiff_t>(at_ + n));
        at_ += n;
        return v;
    }
    std::string get_text() {
        const std::vector<unsigned char> b = get_bytes();
        return std::string(b.begin(), b.end());
    }
    bool done() const { return at_ == in_->size(); }
    std::size_t at() const { return at_; }

private:
    void need(std::size_t n) const {
        if (at_ + n > in_->size()) throw CutShort();
    }
    std::vector<char>* out_ = nullptr;
    const std::vector<char>* in_ = nullptr;
    std::size_t at_ = 0;
};

// What one step's mail holds: a message, a magnet switch, a failure.
enum Item : std::uint8_t { kMessage = 1, kSwitch = 2, kFailure = 3 };

// `bytes` onto process `to`'s outgoing buffer, or every other process's when
// `to` is negative.
void post(std::vector<std::vector<char>>& out, int me, int to, const std::vector<char>& bytes) {
    for (int r = 0; r < static_cast<int>(out.size()); ++r) {
        if (r == me || (to >= 0 && r != to)) continue;
        std::vector<char>& o = out[static_cast<std::size_t>(r)];
        o.insert(o.end(), bytes.begin(), bytes.end());
    }
}

}  // namespace

void ProgramPass::put_catom(std::uint32_t g, std::vector<char>& out) const {
    Bytes b(out);
    const Catom* held = record(g);
    const std::unique_ptr<Catom> fresh = held ? nullptr : fresh_record(g);  // one no process holds
    const Catom& c = held ? *held : *fresh;
    b.put(c.values);
    b.put(static_cast<std::uint8_t>(c.magnets));
    b.put(static_cast<std::uint8_t>(c.started));
    b.put(c.poles_off);
    b.put(c.timer_at);
    b.put(static_cast<std::uint64_t>(c.inbox.size()));
    for (const CatomMessage& m : c.inbox) {
        b.put(m.from);
        b.put(m.data);
    }
    std::vector<unsigned char> bytes;
    c.program->save(bytes);
    b.put_bytes(bytes.data(), bytes.size());
    const std::uint32_t j = spec_->neighbour_events ? now_.place(g) : IdMap::kNone;  // without the events, not kept
    std::vector<std::uint32_t> listed;  // as catom indices
    if (j != IdMap::kNone) {
        for (std::uint32_t q = now_.at[j]; q < now_.at[j + 1]; ++q) {
            listed.push_back(static_cast<std::uint32_t>(numbering_.index(now_.ids[q])));
        }
    }
    b.put_bytes(listed.data(), sizeof(std::uint32_t) * listed.size());
}

std::size_t ProgramPass::get_catom(Catom& c, std::uint32_t g, const std::vector<char>& in, std::size_t at,
                                   std::vector<std::uint32_t>& nbrs) const {
    Bytes b(in, at);
    c.values = b.get<std::array<double, kProgramValues>>();
    c.magnets = b.get<std::uint8_t>() != 0;
    c.started = b.get<std::uint8_t>() != 0;
    c.poles_off = b.get<std::uint8_t>();
    c.timer_at = b.get<double>();
    c.inbox.resize(static_cast<std::size_t>(b.get<std::uint64_t>()));
    for (CatomMessage& m : c.inbox) {
        m.from = b.get<std::uint32_t>();
        m.data = b.get<std::array<std::int64_t, 4>>();
    }
    const std::vector<unsigned char> saved = b.get_bytes();  // outside the try: CutShort must pass
    try {
        c.program->load(saved);
    } catch (const std::exception& e) {
        throw ProgramError("program " + spec_->name + ", catom " + std::to_string(g) + ", restoring: " + e.what());
    }
    const std::vector<unsigned char> list = b.get_bytes();
    nbrs.resize(list.size() / sizeof(std::uint32_t));
    if (!list.empty()) std::memcpy(nbrs.data(), list.data(), list.size());
    for (std::uint32_t& n : nbrs) {
        if (n >= numbering_.count()) throw CheckpointError("the catom programs' state names a neighbour past the scene's catoms");
        n = numbering_.gid(n);
    }
    return b.at();
}

// Catoms owned here last step and not now go, with their record, to their
// new owner (to every process when no copy is held here any more); those
// that arrive keep their last neighbours for this step's lost and gained.
void ProgramPass::transfer(World& world) {
    const int me = coll_->rank();
    ensure_records(owned_.size());
    std::vector<std::vector<char>> out(static_cast<std::size_t>(coll_->ranks()));
    std::vector<char> record;
    std::vector<std::uint32_t> left;  // owned here last step, not now (both lists ascending)
    std::set_difference(last_owned_.begin(), last_owned_.end(), owned_.begin(), owned_.end(), std::back_inserter(left));
    for (std::uint32_t g : left) {
        record.clear();
        Bytes(record).put(g);
        put_catom(g, record);
        const std::uint32_t l = world.local_of(g);
        post(out, me, l != IdMap::kNone ? world.slot(l).owner : -1, record);
    }
    for (std::uint32_t g : left) records_.erase(g);  // sent: its record lives with its new owner
    std::vector<std::uint32_t> nbrs;
    std::unique_ptr<Catom> scratch;
    for (const std::vector<char>& in : coll_->sparse_to(out, 0)) {
        for (std::size_t at = 0; at < in.size();) {
            Bytes b(in, at);
            const auto g = b.get<std::uint32_t>();
            if (!owned_here(world, g)) {  // sent to every process, owned elsewhere: read past it
                if (!scratch) scratch = fresh_record(g);
                at = get_catom(*scratch, g, in, b.at(), nbrs);
                continue;
            }
            std::unique_ptr<Catom>& r = records_.at(g);
            if (!r) r = fresh_record(g);
            at = get_catom(*r, g, in, b.at(), nbrs);
            arrived_[g] = nbrs;  // not owned here last step: its digest is worked out (bind_owned)
        }
    }
    if (sweep_) {  // records made at the set-up for catoms that moved before the first step: keep the owned ones
        records_.keep_only(scene_.body_count(), [&](std::uint32_t g) { return owned_here(world, g); });
        sweep_ = false;
    }
    hold_records();
    unstarted_ = false;  // from now on a catom's state is only where it is owned
}

// The step's mail: messages to catoms owned here go straight into their
// inboxes, the others to their owners; magnet switches into the world and to
// every process; failures to every process (`failed` gets every process's).
// Each inbox ends in sender order (then sending order).
void ProgramPass::exchange_mail(World& world, std::vector<std::pair<std::uint32_t, std::string>>& failed) {
    const int me = coll_->rank();
    std::vector<std::vector<char>> out(static_cast<std::size_t>(coll_->ranks()));
    std::vector<char> item;
    for (std::uint32_t o : ran_) {  // only they may have sent or switched
        Catom& c = *owned_rec_[o];
        for (const auto& [to, m] : c.outbox) {  // `to` is a neighbour: held here
            if (owned_here(world, to)) {
                record(to)->inbox.push_back(m);
                mark_dirty(to);
                continue;
            }
            Bytes b(out[static_cast<std::size_t>(world.slot(world.local_of(to)).owner)]);
            b.put(kMessage), b.put(to), b.put(m.from), b.put(m.data);
        }
        const std::uint32_t g = owned_[o];
        const std::uint8_t off = c.magnets ? c.poles_off : World::kAllPolesOff;
        if (world.poles_off(g) != off) {
            world.switch_poles(g, off);
            item.clear();
            Bytes b(item);
            b.put(kSwitch), b.put(g), b.put(off);
            post(out, me, -1, item);
        }
    }
    for (const auto& [k, what] : failed) {
        item.clear();
        Bytes b(item);
        b.put(kFailure), b.put(k);
        b.put_bytes(what.data(), what.size());
        post(out, me, -1, item);
    }
    if (!distributed()) return;
    std::vector<std::uint32_t> mailed;
    for (const std::vector<char>& in : coll_->sparse_to(out, 1)) {
        for (Bytes b(in, 0); !b.done();) {
            const auto what = b.get<std::uint8_t>();
            if (what == kMessage) {
                const auto to = b.get<std::uint32_t>();
                CatomMessage m;
                m.from = b.get<std::uint32_t>();
                m.data = b.get<std::array<std::int64_t, 4>>();
                if (!owned_here(world, to)) throw std::logic_error("a message for catom " + std::to_string(to) + ", not owned here");
                record(to)->inbox.push_back(m);
                mark_dirty(to);
                mailed.push_back(to);
            } else if (what == kSwitch) {
                const auto g = b.get<std::uint32_t>();
                world.switch_poles(g, b.get<std::uint8_t>());
            } else {
                const auto k = b.get<std::uint32_t>();
                failed.emplace_back(k, b.get_text());
            }
        }
    }
    for (std::uint32_t g : mailed) {
        std::vector<CatomMessage>& inbox = record(g)->inbox;
        std::stable_sort(inbox.begin(), inbox.end(),
                         [](const CatomMessage& a, const CatomMessage& b) { return a.from < b.from; });
    }
}

// Every catom's record in catom order, each from the process that owns it
// (the writer's copy for a catom no process owns): the same bytes whatever
// the number of processes, made on the last process alone, a piece of
// kStatePiece catoms at a time (no process holds the scene's records).
// Piece 0 is the section's head: the catom count, the step and the counts.
std::size_t ProgramPass::state_pieces() const { return 1 + (numbering_.count() + kStatePiece - 1) / kStatePiece; }

void ProgramPass::state_piece(std::size_t k, std::vector<char>& out) const {
    const bool writer = coll_->last();
    if (k == 0) {
        const ProgramCounts counted = totals();  // collective when distributed
        if (!writer) return;
        Bytes b(out);
        b.put(static_cast<std::uint64_t>(numbering_.count()));
        b.put(static_cast<std::int64_t>(step_));
        b.put(counts_.steps);
        b.put(counted.messages);
        b.put(counted.events);
        return;
    }
    const std::size_t lo = (k - 1) * kStatePiece, hi = std::min(numbering_.count(), k * kStatePiece);
    if (!distributed()) {
        for (std::size_t i = lo; i < hi; ++i) put_catom(numbering_.gid(i), out);
        return;
    }
    std::vector<char> mine, one;  // (catom, length, record) of each catom of the piece run here
    const auto first = std::lower_bound(last_owned_.begin(), last_owned_.end(), numbering_.gid(lo));
    const auto last = std::upper_bound(first, last_owned_.end(), numbering_.gid(hi - 1));  // catom order is gid order
    for (auto it = first; it != last; ++it) {
        one.clear();
        put_catom(*it, one);
        Bytes(mine).put(*it);
        Bytes(mine).put(static_cast<std::uint64_t>(one.size()));
        mine.insert(mine.end(), one.begin(), one.end());
    }
    const auto to = static_cast<std::size_t>(coll_->ranks() - 1);
    std::vector<std::vector<char>> send(to + 1);
    send[to] = std::move(mine);
    const std::vector<std::vector<char>> all = coll_->sparse_to(send, 2);
    if (writer) assemble_piece(all, lo, hi, out);
}

// The writer's piece [lo, hi) in catom order from what every process sent.
void ProgramPass::assemble_piece(const std::vector<std::vector<char>>& all, std::size_t lo, std::size_t hi,
                                 std::vector<char>& out) const {
    std::vector<std::pair<const char*, std::size_t>> from(hi - lo, {nullptr, 0});  // by catom index - lo
    for (const std::vector<char>& in : all) {
        for (Bytes r(in, 0); !r.done();) {
            const auto g = r.get<std::uint32_t>();
            const auto n = static_cast<std::size_t>(r.get<std::uint64_t>());
            from[numbering_.index(g) - lo] = {in.data() + r.at(), n};
            r = Bytes(in, r.at() + n);
        }
    }
    for (std::size_t i = 0; i < from.size(); ++i) {
        if (from[i].first) {
            out.insert(out.end(), from[i].first, from[i].first + from[i].second);
        } else {
            put_catom(numbering_.gid(lo + i), out);
        }
    }
}

// A checkpoint's section, read window by window: each process keeps the
// records of the catoms it owns and reads past the others'.
void ProgramPass::load_state(World& world, ByteSource& state) {
    std::vector<char> window;
    std::size_t at = 0;
    state.refill(window, at);
    Bytes b(window, 0);
    const std::size_t count = numbering_.count();
    if (b.get<std::uint64_t>() != count) {
        throw CheckpointError("the catom programs' state in the checkpoint is for another number of catoms");
    }
    step_ = static_cast<long>(b.get<std::int64_t>());
    counts_.steps = b.get<std::uint64_t>();
    counts_.messages = b.get<std::uint64_t>();
    counts_.events = b.get<std::uint64_t>();
    if (coll_->rank() != 0) counts_.messages = counts_.events = 0;  // the totals counted once, on the first process
    at = b.at();
    located_ = ~0ULL;
    locate(world);  // the catoms this process owns after the set-up
    now_.keys = owned_;
    now_.at.assign(1, 0);
    now_.ids.clear();
    std::vector<std::uint32_t> nbrs;
    ensure_records(owned_.size());
    std::unique_ptr<Catom> scratch;  // the records of catoms owned elsewhere are read past
    for (std::size_t k = 0, next = 0; k < count; ++k) {  // gids ascending, as owned_: `next` walks it
        const std::uint32_t g = numbering_.gid(k);
        const bool mine = next < owned_.size() && owned_[next] == g;
        next += mine;
        std::unique_ptr<Catom>& r = mine ? records_.at(g) : scratch;
        if (!r) r = fresh_record(g);
        at = next_catom(*r, g, state, window, at, nbrs);
        if (mine) {
            now_.ids.insert(now_.ids.end(), nbrs.begin(), nbrs.end());
            now_.at.push_back(static_cast<std::uint32_t>(now_.ids.size()));
        }
        world.switch_poles(g, r->magnets ? r->poles_off : World::kAllPolesOff);  // every process keeps every switch
    }
    if (at != window.size() || state.refill(window, at)) {
        throw CheckpointError("the catom programs' state in the checkpoint is longer than its catoms'");
    }
    unstarted_ = false;  // every owned catom has its record; those that move later travel with it
    sweep_ = false;
    last_owned_ = owned_;
    bind_owned();
    std::fill(dirty_.begin(), dirty_.end(), 1);
    refresh_world(world, true);
}

// The record of catom g from the window at `at`, refilled from `state` while
// the record runs past its end (a record's length is known only once read).
std::size_t ProgramPass::next_catom(Catom& c, std::uint32_t g, ByteSource& state, std::vector<char>& window,
                                    std::size_t at, std::vector<std::uint32_t>& nbrs) const {
    for (;;) {
        try {
            return get_catom(c, g, window, at, nbrs);
        } catch (const CutShort&) {
            if (!state.refill(window, at)) throw;
        }
    }
}

std::vector<double> ProgramPass::values_of(int v) const {
    std::vector<double> out(numbering_.count(), 0.0);  // not held here: the owner's below
    records_.each([&](std::uint32_t g, const Catom& r) { out[numbering_.index(g)] = r.values.at(static_cast<std::size_t>(v)); });
    if (!distributed()) return out;
    std::vector<char> mine;
    for (std::uint32_t g : last_owned_) Bytes(mine).put(g), Bytes(mine).put(out[numbering_.index(g)]);
    for (const std::vector<char>& in : coll_->all_gather(mine)) {
        for (Bytes b(in, 0); !b.done();) {
            const auto g = b.get<std::uint32_t>();
            out[numbering_.index(g)] = b.get<double>();
        }
    }
    return out;
}

}  // namespace parode
