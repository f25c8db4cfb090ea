// The catom programs' state between processes and in checkpoints (see
// program_pass.hpp): a catom's record travels to its new owner when it
// migrates; each step's mail goes to the receivers' owners, magnet switches
// and failures to every process; checkpoints hold every catom's record in
// catom order whatever the number of processes.
// Trade-off: one sparse exchange for the migrants and one for the mail a
// step (messages only to the processes that get something, then a
// non-blocking barrier: no count from every process, so it scales with the
// neighbours, not the machine), kept apart from the ghost exchange, which
// runs before the handlers have sent anything; switches go to every process,
// which costs little while programs switch rarely and keeps every ghost's
// magnets right wherever it appears.
#include <algorithm>
#include <cstring>

#include "programs/catom_state.hpp"
#include "programs/program_pass.hpp"
#include "util/errors.hpp"
#include "util/id_map.hpp"

namespace parode {
namespace {

// Plain values appended to and read from a byte buffer.
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
        if (at_ + n > in_->size()) throw CheckpointError("the catom programs' state in the checkpoint is cut short");
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

void ProgramPass::put_catom(std::size_t k, std::vector<char>& out) const {
    Bytes b(out);
    const std::unique_ptr<Catom> fresh = catoms_[k] ? nullptr : fresh_record(k);  // one no process holds
    const Catom& c = catoms_[k] ? *catoms_[k] : *fresh;
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
    const bool listed = spec_->neighbour_events && k + 1 < now_.at.size();  // without the events, not kept
    const std::uint32_t n0 = listed ? now_.at[k] : 0, n1 = listed ? now_.at[k + 1] : 0;
    b.put_bytes(now_.ids.data() + n0, sizeof(std::uint32_t) * (n1 - n0));
}

std::size_t ProgramPass::get_catom(Catom& c, std::size_t k, const std::vector<char>& in, std::size_t at,
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
    try {
        c.program->load(b.get_bytes());
    } catch (const std::exception& e) {
        throw ProgramError("program " + spec_->name + ", catom " + std::to_string(ids_[k]) + ", restoring: " + e.what());
    }
    const std::vector<unsigned char> list = b.get_bytes();
    nbrs.resize(list.size() / sizeof(std::uint32_t));
    if (!list.empty()) std::memcpy(nbrs.data(), list.data(), list.size());
    return b.at();
}

// Catoms owned here last step and not now go, with their record, to their
// new owner (to every process when no copy is held here any more); those
// that arrive keep their last neighbours for this step's lost and gained.
void ProgramPass::transfer(World& world) {
    const int me = coll_->rank();
    std::vector<std::vector<char>> out(static_cast<std::size_t>(coll_->ranks()));
    std::vector<char> record;
    for (std::uint32_t k : last_owned_) {
        if (owned_now_[k]) continue;
        record.clear();
        Bytes(record).put(k);
        put_catom(k, record);
        post(out, me, local_k_[k] != IdMap::kNone ? world.slot(local_k_[k]).owner : -1, record);
    }
    for (std::uint32_t k : last_owned_) {
        if (!owned_now_[k]) catoms_[k].reset();  // sent: its record lives with its new owner
    }
    std::vector<std::uint32_t> nbrs;
    std::unique_ptr<Catom> scratch;
    for (const std::vector<char>& in : coll_->sparse_to(out, 0)) {
        for (std::size_t at = 0; at < in.size();) {
            Bytes b(in, at);
            const auto k = b.get<std::uint32_t>();
            if (!owned_now_[k]) {  // sent to every process, owned elsewhere: read past it
                if (!scratch) scratch = fresh_record(k);
                at = get_catom(*scratch, k, in, b.at(), nbrs);
                continue;
            }
            if (!catoms_[k]) catoms_[k] = fresh_record(k);
            at = get_catom(*catoms_[k], k, in, b.at(), nbrs);
            arrived_[k] = nbrs;
            dirty_[k] = 1;
        }
    }
    if (sweep_) {  // after a restart every process held every record: keep the owned ones
        for (std::size_t k = 0; k < catoms_.size(); ++k) {
            if (!owned_now_[k]) catoms_[k].reset();
        }
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
    for (std::uint32_t k : ran_) {  // only they may have sent or switched
        Catom& c = *catoms_[k];
        for (const auto& [to, m] : c.outbox) {
            const std::uint32_t kt = kof_[to];
            if (owned_now_[kt]) {
                catoms_[kt]->inbox.push_back(m);
                dirty_[kt] = 1;
                continue;
            }
            Bytes b(out[static_cast<std::size_t>(world.slot(local_k_[kt]).owner)]);
            b.put(kMessage), b.put(kt), b.put(m.from), b.put(m.data);
        }
        const std::uint8_t off = c.magnets ? c.poles_off : World::kAllPolesOff;
        if (world.poles_off(ids_[k]) != off) {
            world.switch_poles(ids_[k], off);
            item.clear();
            Bytes b(item);
            b.put(kSwitch), b.put(ids_[k]), b.put(off);
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
                const auto kt = b.get<std::uint32_t>();
                CatomMessage m;
                m.from = b.get<std::uint32_t>();
                m.data = b.get<std::array<std::int64_t, 4>>();
                if (!owned_now_[kt]) throw std::logic_error("a message for catom " + std::to_string(ids_[kt]) + ", not owned here");
                catoms_[kt]->inbox.push_back(m);
                dirty_[kt] = 1;
                mailed.push_back(kt);
            } else if (what == kSwitch) {
                const auto g = b.get<std::uint32_t>();
                world.switch_poles(g, b.get<std::uint8_t>());
            } else {
                const auto k = b.get<std::uint32_t>();
                failed.emplace_back(k, b.get_text());
            }
        }
    }
    for (std::uint32_t k : mailed) {
        std::stable_sort(catoms_[k]->inbox.begin(), catoms_[k]->inbox.end(),
                         [](const CatomMessage& a, const CatomMessage& b) { return a.from < b.from; });
    }
}

// Every catom's record in catom order, each from the process that owns it
// (this one's copy for a catom no process owns): the same bytes on every
// process, whatever their number.
std::vector<char> ProgramPass::save_state() const {
    std::vector<char> out;
    Bytes b(out);
    b.put(static_cast<std::uint64_t>(ids_.size()));
    b.put(static_cast<std::int64_t>(step_));
    b.put(counts_.steps);
    const ProgramCounts counted = totals();
    b.put(counted.messages);
    b.put(counted.events);
    if (!distributed()) {
        for (std::size_t k = 0; k < catoms_.size(); ++k) put_catom(k, out);
        return out;
    }
    std::vector<char> mine, record;  // (catom, length, record) of each catom run here
    for (std::uint32_t k : last_owned_) {
        record.clear();
        put_catom(k, record);
        Bytes(mine).put(k);
        Bytes(mine).put(static_cast<std::uint64_t>(record.size()));
        mine.insert(mine.end(), record.begin(), record.end());
    }
    std::vector<std::pair<const char*, std::size_t>> from(catoms_.size(), {nullptr, 0});
    const std::vector<std::vector<char>> all = coll_->all_gather(mine);
    for (const std::vector<char>& in : all) {
        for (Bytes r(in, 0); !r.done();) {
            const auto k = r.get<std::uint32_t>();
            const auto n = static_cast<std::size_t>(r.get<std::uint64_t>());
            from[k] = {in.data() + r.at(), n};
            Bytes skip(in, r.at() + n);
            r = skip;
        }
    }
    std::vector<char> own;
    for (std::size_t k = 0; k < catoms_.size(); ++k) {
        if (from[k].first) {
            out.insert(out.end(), from[k].first, from[k].first + from[k].second);
        } else {
            own.clear();
            put_catom(k, own);
            out.insert(out.end(), own.begin(), own.end());
        }
    }
    return out;
}

void ProgramPass::load_state(World& world, const std::vector<char>& state) {
    Bytes b(state, 0);
    if (b.get<std::uint64_t>() != ids_.size()) {
        throw CheckpointError("the catom programs' state in the checkpoint is for another number of catoms");
    }
    step_ = static_cast<long>(b.get<std::int64_t>());
    counts_.steps = b.get<std::uint64_t>();
    counts_.messages = b.get<std::uint64_t>();
    counts_.events = b.get<std::uint64_t>();
    if (coll_->rank() != 0) counts_.messages = counts_.events = 0;  // the totals counted once, on the first process
    now_.at.assign(ids_.size() + 1, 0);
    now_.ids.clear();
    std::size_t at = b.at();
    std::vector<std::uint32_t> nbrs;
    for (std::size_t k = 0; k < catoms_.size(); ++k) {
        if (!catoms_[k]) catoms_[k] = fresh_record(k);
        at = get_catom(*catoms_[k], k, state, at, nbrs);
        now_.ids.insert(now_.ids.end(), nbrs.begin(), nbrs.end());
        now_.at[k + 1] = static_cast<std::uint32_t>(now_.ids.size());
    }
    if (at != state.size()) throw CheckpointError("the catom programs' state in the checkpoint is longer than its catoms'");
    unstarted_ = true;  // every process holds every catom's state now
    std::fill(dirty_.begin(), dirty_.end(), 1);
    sweep_ = distributed();
    last_owned_.clear();
    for (std::size_t k = 0; k < catoms_.size(); ++k) {
        world.switch_poles(ids_[k], catoms_[k]->magnets ? catoms_[k]->poles_off : World::kAllPolesOff);
    }
    located_ = ~0ULL;
    locate(world);
    refresh_world(world, true);
}

std::vector<double> ProgramPass::values_of(int v) const {
    std::vector<double> out(catoms_.size());
    for (std::size_t k = 0; k < catoms_.size(); ++k) {
        out[k] = catoms_[k] ? catoms_[k]->values.at(static_cast<std::size_t>(v)) : 0.0;  // not held here: the owner's below
    }
    if (!distributed()) return out;
    std::vector<char> mine;
    for (std::uint32_t k : last_owned_) Bytes(mine).put(k), Bytes(mine).put(out[k]);
    for (const std::vector<char>& in : coll_->all_gather(mine)) {
        for (Bytes b(in, 0); !b.done();) {
            const auto k = b.get<std::uint32_t>();
            out[k] = b.get<double>();
        }
    }
    return out;
}

}  // namespace parode
