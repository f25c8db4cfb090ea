// The contact solver's exchange on a distributed run (MpiDomain as the
// solver's CorrectionExchange, mpi_domain.hpp): after each colour of each
// sweep, the corrections of the bodies this process's cells of that colour
// touched go to every other holder of them. The bodies' ids travel with a
// colour's first message of the step, the other twenty carry only the
// corrections, copied in and out by memcpy.
// Trade-off: each side keeps a colour's lists for the step (a few bytes a
// shared body per colour) to save parsing and an id lookup per body in
// every message.
#include "mpi_domain.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

namespace parode::mpi {

// A new token for mark_: the marks of earlier passes lapse (a step has 1 +
// neighbours passes, so the bytes are cleared every few steps).
std::uint8_t MpiDomain::next_mark() {
    mark_.resize(world_->body_count(), 0);
    if (++mark_token_ == 0) {
        std::fill(mark_.begin(), mark_.end(), 0);
        mark_token_ = 1;
    }
    return mark_token_;
}

// Interest: each rank tells each neighbour which of the bodies they both
// hold it touches this step (any colour), and learns theirs. A neighbour
// needs a body's corrections only if it touches the body or owns it (to
// integrate it); a ghost it never touches keeps its state until the next
// exchange of states, so its corrections are not sent. One message each
// way a step.
void MpiDomain::exchange_interest(const std::vector<std::vector<std::uint32_t>>& touched) {
    std::vector<Bytes> out(nbrs_.size());
    const std::uint8_t once = next_mark();
    for (const auto& list : touched) {
        for (std::uint32_t b : list) {
            if (mark_[b] == once) continue;
            mark_[b] = once;
            for (int h : holders(world_->slot(b))) {
                if (h != rank()) put(out[static_cast<std::size_t>(nbr_index_[static_cast<std::size_t>(h)])], world_->gid(b));
            }
        }
    }
    comm_.exchange(nbrs_, out, nbrs_, interest_in_, kTagInterest);
}

void MpiDomain::plan(const std::vector<std::vector<std::uint32_t>>& touched) {
    exchange_interest(touched);
    corr_.resize(touched.size());
    corr_in_.resize(touched.size());
    corr_named_.assign(touched.size(), 0);
    for (std::size_t c = 0; c < touched.size(); ++c) {
        corr_[c].assign(nbrs_.size(), {});
        corr_in_[c].assign(nbrs_.size(), {});
    }
    for (std::size_t j = 0; j < nbrs_.size(); ++j) {
        const std::uint8_t wants = next_mark();
        const Bytes& in = interest_in_[j];
        for (std::size_t at = 0; at + sizeof(std::uint32_t) <= in.size();) {
            const std::uint32_t local = world_->local_of(take<std::uint32_t>(in, at));
            if (local != IdMap::kNone) mark_[local] = wants;
        }
        const int h = nbrs_[j];
        for (std::size_t c = 0; c < touched.size(); ++c) {
            for (std::uint32_t b : touched[c]) {
                const DomainSlot& s = world_->slot(b);
                if (mark_[b] != wants && s.owner != h) continue;
                const std::vector<int>& hs = holders(s);
                if (std::find(hs.begin(), hs.end(), h) != hs.end()) corr_[c][j].push_back(b);
            }
        }
    }
}

namespace {

constexpr std::size_t kSix = 6 * sizeof(double);  // one body's corrections

// A message of the solve's exchange: on a colour's first exchange of the step,
// the count and ids of the bodies, then (always) their six corrections each.
void pack_corrections(const World& world, const std::vector<std::uint32_t>& list, bool named, const CorrectionView& fc,
                      Bytes& out) {
    const std::size_t head = named ? sizeof(std::uint32_t) * (1 + list.size()) : 0;
    out.resize(head + list.size() * kSix);
    char* w = out.data();
    if (named) {
        const auto n = static_cast<std::uint32_t>(list.size());
        std::memcpy(w, &n, sizeof n);
        w += sizeof n;
        for (std::uint32_t b : list) {
            const std::uint32_t gid = world.gid(b);
            std::memcpy(w, &gid, sizeof gid);
            w += sizeof gid;
        }
    }
    for (std::uint32_t b : list) {
        std::memcpy(w, fc.of(b), kSix);
        w += kSix;
    }
}

}  // namespace

void MpiDomain::bad_message(std::size_t j, std::size_t got, std::size_t expected, bool more) const {
    throw std::runtime_error("rank " + std::to_string(rank()) + ": a correction message from rank " +
                             std::to_string(nbrs_[j]) + " has " + (more ? "more than " : "") + std::to_string(got) +
                             " bytes, not the " + std::to_string(expected) + " expected");
}

// Without overlap every body counts as shared: every cell is a boundary
// cell, relaxed before the exchange, as one blocking exchange a colour.
bool MpiDomain::shared(std::uint32_t local) const {
    if (!scene_.parallel.overlap) return true;
    const DomainSlot& s = world_->slot(local);
    return s.holders && s.holders->size() > 1;
}

// The ids travel once a step per colour and neighbour; the other 20 messages
// of the colour carry only corrections, which go straight to the locals
// learnt from the first (both sides call plan() each step and then exchange
// the colours in the same sequence, so they agree which message is first).
// Those later messages have sizes known in advance: their receives are
// posted at once, so that the data move while the interior cells relax.
void MpiDomain::post(int colour, const CorrectionView& fc) {
    const auto c = static_cast<std::size_t>(colour);
    const bool named = !corr_named_[c];
    corr_named_[c] = 1;
    const std::size_t n = nbrs_.size();
    corr_out_.resize(n);
    for (std::size_t j = 0; j < n; ++j) {
        pack_corrections(*world_, corr_[c][j], named, fc, corr_out_[j]);
        colour_bytes_[c] += corr_out_[j].size();
    }
    expect_.resize(n);
    for (std::size_t j = 0; j < n; ++j) expect_[j] = corr_in_[c][j].size() * kSix;
    comm_.post_exchange(nbrs_, corr_out_, nbrs_, corr_recv_, named ? nullptr : &expect_, kTagCorrection, pending_);
    posted_named_ = named;
}

void MpiDomain::complete(int colour, const CorrectionView& fc) {
    const auto c = static_cast<std::size_t>(colour);
    const bool named = posted_named_;
    const std::size_t n = nbrs_.size();
    try {
        comm_.complete_exchange(pending_);
    } catch (const MessageTooLong& e) {
        bad_message(e.index, e.expected, e.expected, true);
    }
    for (std::size_t j = 0; j < n; ++j) {
        const Bytes& b = corr_recv_[j];
        const char* r = b.data();
        std::vector<std::uint32_t>& locals = corr_in_[c][j];
        if (named) {
            std::uint32_t count = 0;
            if (b.size() >= sizeof count) std::memcpy(&count, r, sizeof count);
            r += sizeof count;
            const std::size_t ids_end = sizeof count * (1 + std::size_t{count});
            if (b.size() < ids_end) bad_message(j, b.size(), ids_end);
            locals.resize(count);
            for (std::uint32_t& l : locals) {
                std::uint32_t gid = 0;
                std::memcpy(&gid, r, sizeof gid);
                r += sizeof gid;
                l = world_->local_of(gid);
            }
        }
        const std::size_t head = static_cast<std::size_t>(r - b.data());
        if (b.size() != head + locals.size() * kSix) bad_message(j, b.size(), head + locals.size() * kSix);
        for (std::uint32_t l : locals) {
            std::memcpy(fc.of(l), r, kSix);
            r += kSix;
        }
    }
}

// One maximum over the processes (exact).
bool MpiDomain::any(bool mine) { return collectives_.max(mine ? 1.0 : 0.0) > 0; }

}  // namespace parode::mpi
