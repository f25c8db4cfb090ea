// The adaptive contact solver's sweeps (solver "adaptive", contact_solver.hpp):
// solver.adaptive_sweeps sweeps of every cell, the last of them noting each
// cell's largest change (m1 + m2 times the largest change of a contact's
// impulses: how much its relaxation moved a relative velocity); then sweeps
// of only the cells whose change, times the step, is above solver.tolerance,
// colour by colour, until none is or solver.extra_sweeps have run. A cell's
// change is its own contacts' arithmetic, so the cells listed, and every bit
// of the result, are the same for any thread and rank count: the sweeps of
// listed cells keep the colours' order and their exchange between processes
// (a process with no listed cell of a colour still exchanges; every process
// runs the same number of sweeps, which `CorrectionExchange::any` agrees).
// Where a pile settles, few cells stay above the tolerance; where a fast body
// strikes, its cells are swept until the impulse has gone through.
// Trade-off: one more pass over the cells a sweep (listing them) and
// bookkeeping per contact in the listed sweeps, against sweeps of every cell
// that change next to nothing.
#include <algorithm>

#include "solve/contact_solver.hpp"

namespace parode {

void ContactSolver::iterate() {
    const int fixed = adaptive_ ? scene_.solver.adaptive_sweeps - 1 : iterations();
    {
        SubstageTimer t(times_, "sweeps");
        sweep(fixed, false);
    }
    if (!adaptive_) return;
    SubstageTimer t(times_, "active");
    active_sweeps();
}

void ContactSolver::active_sweeps() {
    ++active_work_.steps;
    active_work_.contacts += static_cast<std::int64_t>(contact_count());
    cell_change_.assign(layout_.cells(), 0.0);
    bool more = list_cells(true);  // the last sweep of every cell, its changes noted
    for (int extra = 0; more; ++extra) {
        list_sweep();
        ++active_work_.sweeps;
        active_work_.relaxed += static_cast<std::int64_t>(listed_pos_.back());
        more = extra < scene_.solver.extra_sweeps && list_cells(false);
    }
}

bool ContactSolver::list_cells(bool all) {
    const double bound = scene_.solver.tolerance / h_;
    listed_.clear();
    listed_pos_.assign(1, 0);
    for (int k = 0; k < 2 * kColours; ++k) {
        listed_start_[static_cast<std::size_t>(k)] = listed_.size();
        const int c = k / 2;
        const std::size_t t0 = k % 2 ? layout_.boundary_end(c) : layout_.colour_begin(c);
        const std::size_t t1 = k % 2 ? layout_.colour_end(c) : layout_.boundary_end(c);
        for (std::size_t t = t0; t < t1; ++t) {
            if (!all && !(cell_change_[t] > bound)) continue;
            listed_.push_back(static_cast<std::uint32_t>(t));
            listed_pos_.push_back(listed_pos_.back() + (layout_.cell_begin(t + 1) - layout_.cell_begin(t)));
        }
    }
    listed_start_[2 * kColours] = listed_.size();
    const bool mine = !listed_.empty();
    return exchange_ ? exchange_->any(mine) : mine;
}

void ContactSolver::list_sweep() {
    for (int c = 0; c < kColours; ++c) {
        relax_listed(listed_begin(2 * c), listed_begin(2 * c + 1));
        if (exchange_) post_after_boundary(c);
        relax_listed(listed_begin(2 * c + 1), listed_begin(2 * c + 2));
        if (exchange_) complete_after_interior(c);
    }
}

namespace {

// Where one stream of listed cells stands: its entry in the list and the
// entry it stops at, its contact and the end of that contact's cell, and the
// largest change of the cell so far.
struct Stream {
    std::size_t entry, stop, p, cell_end;
    double most;
};

}  // namespace

// As relax_cells, over entries [a0, a1) of the list: `streams` runs of whole
// cells with about equal numbers of contacts, a contact of each a round; as
// a stream leaves a cell, the cell's largest change is noted.
void ContactSolver::relax_listed(std::size_t a0, std::size_t a1) {
    if (a0 == a1) return;
    const int streams = eight_lanes() ? 8 : 4;
    Stream st[kMostStreams];
    int live = 0;
    const auto enter = [&](Stream& s) {
        const std::size_t t = listed_[s.entry];
        s.p = layout_.cell_begin(t);
        s.cell_end = layout_.cell_begin(t + 1);
        s.most = 0;
    };
    std::size_t entry = a0;
    const std::size_t c0 = listed_pos_[a0], c1 = listed_pos_[a1];
    for (int s = 0; s < streams && entry < a1; ++s) {
        const std::size_t target = c0 + (c1 - c0) * static_cast<std::size_t>(s + 1) / static_cast<std::size_t>(streams);
        std::size_t stop = entry + 1;
        while (stop < a1 && listed_pos_[stop] < target) ++stop;
        if (s == streams - 1) stop = a1;
        st[live] = Stream{entry, stop, 0, 0, 0};
        enter(st[live++]);
        entry = stop;
    }
    const auto step_on = [&](Stream& s, double change) {
        s.most = std::max(s.most, change);
        if (++s.p < s.cell_end) return;
        cell_change_[listed_[s.entry]] = s.most;
        if (++s.entry < s.stop) enter(s);
    };
    BodyRow* hot = hot_.data();
    SphereRow* pack[kMostStreams];
    Stream* owner[kMostStreams];
    double change[kMostStreams];
    for (;;) {
        int held = 0;
        for (int s = 0; s < live; ++s) {
            Stream& S = st[s];
            if (S.entry == S.stop) continue;
            prefetch_ahead(rows_.data(), rows_.size(), hot, S.p);
            SphereRow& K = rows_[S.p];
            if (K.b1 < 0) {
                double ch = 0;
                relax(blocks_[static_cast<std::size_t>(-1 - K.b1)], hot, &ch);
                step_on(S, ch);
                continue;
            }
            owner[held] = &S;
            pack[held++] = &K;
        }
        if (held == 0) {
            bool busy = false;
            for (int s = 0; s < live; ++s) busy |= st[s].entry != st[s].stop;
            if (!busy) return;
            continue;
        }
        relax_pack(pack, held, change);
        for (int l = 0; l < held; ++l) step_on(*owner[l], change[l]);
    }
}

}  // namespace parode
