// Distributed runs end to end: `parode run` under mpiexec on 1, 2 and 3
// processes and 1..3 threads (2 x 2 among them) gives the state hash of the run without MPI
// (with migrations and repartitions happening, invariants checked every
// step), writes the same trajectory, snapshot and dump files, refuses scenes
// it cannot distribute with one message, stops every process together when
// the guard fires on one, and ends every process when one fails alone.
// Trade-off: real processes through the real launcher (oversubscribed on a
// small machine, passive waiting) test what a cluster user runs, at a few
// seconds per case; scenes are kept to 2,000 catoms.
#include "mpi_runs.hpp"

namespace {

using namespace mpi_runs;

TEST_P(Ranks, SameStateHashAsOneProcess) {
    same_hash({{GetParam(), 1, 2}, {GetParam(), 2, 1}, {GetParam(), 3, 1}, {GetParam(), 2, 2}});
}

INSTANTIATE_TEST_SUITE_P(Classic, Ranks, ::testing::Values("tennis", "magnetic-tennis"));

// The solver tests' run: 2,000 tennis catoms over 150 steps on `solver`,
// repartitioned whenever the balance drifts 2 % (checked every 5 steps), so
// bodies migrate between the processes.
std::string migrating_prism(const std::string& solver) {
    return " run " + kSource + "/jobs/scenes/tennis.toml --steps 150 --collide grid --solver " + solver +
           " -q --check-invariants 1 --set catoms.count=2000"
           " --set parallel.rebalance_threshold=1.02 --set parallel.rebalance_every=5";
}

// The solver's substeps advance ghosts as their owners advance them: the same
// state hash for 1 and 2 threads and 2 and 3 processes, and not the hash
// without substeps (the setting took effect).
TEST_F(Mpi, SubstepsSameStateHashOnAnyRanksAndThreads) {
    const std::string common = migrating_prism("parallel");
    const std::string sub = common + " --set solver.substeps=4 --set solver.iterations=3";
    ASSERT_EQ(run(0, common + " --threads 1 --report " + path("plain.json")).rc, 0);
    ASSERT_EQ(run(0, sub + " --threads 1 --report " + path("ref.json")).rc, 0);
    const nlohmann::json ref = report("ref.json");
    EXPECT_NE(ref["state_hash"], report("plain.json")["state_hash"]);
    expect_ref_hash(sub, ref, {{0, 2}, {2, 1}, {3, 1}}, "sub");
}

// The adaptive solver lists the cells it sweeps again on each process from
// their own changes, and the processes agree how many sweeps run: the same
// state hash for 1 and 2 threads and 2 and 3 processes (2 x 2 among them),
// with migrations and repartitions, and not the hash of its fixed sweeps
// alone (the listed sweeps ran).
TEST_F(Mpi, AdaptiveSolverSameStateHashOnAnyRanksAndThreads) {
    const std::string adaptive = migrating_prism("adaptive/omp");
    ASSERT_EQ(run(0, adaptive + " --set solver.tolerance=1e9 --threads 1 --report " + path("fixed.json")).rc, 0);
    ASSERT_EQ(run(0, adaptive + " --threads 1 --report " + path("ref.json")).rc, 0);
    const nlohmann::json ref = report("ref.json");
    EXPECT_NE(ref["state_hash"], report("fixed.json")["state_hash"]);
    EXPECT_GT(ref["solver"]["active"]["sweeps_per_step"].get<double>(), 1.0);
    expect_ref_hash(adaptive, ref, {{0, 2}, {2, 1}, {3, 1}, {2, 2}}, "adaptive");
}

// A prism sliding sideways carries bodies across the cuts every step: each
// rank's table of geoms changes (migrants change hands, ghosts leave and
// enter the halo) and its neighbour list is patched rather than built again
// (neighbour_patch.cpp). The state hash is one process's on 3 ranks and on
// 2 ranks x 2 threads, with invariants checked every step (red when the
// renumbered lists lose a pair; the arrivals' own pairs are
// test_neighbour_list's: here new ghosts enter at the halo's edge, beyond
// touching an owned body while the list lives).
TEST_F(Mpi, BodiesCrossingTheCutsPatchTheListSameStateHash) {
    const std::string common = " run " + kSource + "/jobs/scenes/tennis.toml --steps 30 --collide grid"
                               " --solver parallel -q --check-invariants 1 --set catoms.count=8000"
                               " --set catoms.velocity=[4,1,0]";
    ASSERT_EQ(run(0, common + " --threads 1 --report " + path("one.json")).rc, 0);
    for (const Case c : {Case{"", 3, 1}, Case{"", 2, 2}}) {
        const std::string name = "cross" + std::to_string(c.ranks) + "x" + std::to_string(c.threads) + ".json";
        const Result r = run(c.ranks, common + " --threads " + std::to_string(c.threads) + " --report " + path(name));
        ASSERT_EQ(r.rc, 0) << r.err;
        const nlohmann::json rep = report(name);
        EXPECT_EQ(rep["state_hash"], report("one.json")["state_hash"]) << c.ranks << " ranks x " << c.threads << " threads";
        EXPECT_GT(rep["parallel"]["migrations"].get<long>(), 0) << rep["parallel"].dump();
        EXPECT_GT(rep["collide_counts"]["neighbour_list_patches"].get<long>(), 0) << rep["collide_counts"].dump();
    }
}

// The processes cutting the bisection's tree together (partitioner
// "bisection"; by default beyond partition.hpp's kGatherUnits cells) keep no
// map of cells: the same state hash as one process on 2 and 3 processes,
// with repartitions made the same way and invariants (one owner per body,
// each in its owner's cells, ghosts equal to owners) checked every step; the
// prism's parts balanced as the root's bisection balances them.
TEST_F(Mpi, TreeCutTogetherSameStateHash) {
    const std::string common = " run " + kSource + "/jobs/scenes/tennis.toml --steps 150 --collide grid"
                               " --solver parallel -q --check-invariants 1 --set catoms.count=2000 --threads 1"
                               " --set parallel.rebalance_threshold=1.02 --set parallel.rebalance_every=5";
    ASSERT_EQ(run(0, common + " --report " + path("one.json")).rc, 0);
    for (int ranks : {2, 3}) {
        const std::string name = "tree" + std::to_string(ranks) + ".json";
        const Result r = run(ranks, common + " --set parallel.partitioner='\"bisection\"' --report " + path(name));
        ASSERT_EQ(r.rc, 0) << r.err;
        const nlohmann::json rep = report(name);
        EXPECT_EQ(rep["state_hash"], report("one.json")["state_hash"]) << ranks << " ranks";
        const nlohmann::json& par = rep["parallel"];
        EXPECT_EQ(par["partition_made_by"], "every process");
        EXPECT_EQ(par["cut_tree_nodes"].get<int>(), 2 * ranks - 1);
        EXPECT_EQ(par["mapped_blocks"].get<int>(), 0);
        EXPECT_GT(par["repartitions"].get<int>(), 0);
        EXPECT_LT(par["partition_imbalance"].get<double>(), 1.01);
    }
}

// A checkpoint written by 2 processes restarts on 1, 2 and 3 processes with
// the hash of the uninterrupted run; each process builds the bodies it will
// own from the checkpoint's positions, so none moves at setup.
TEST_F(Mpi, CheckpointOfTwoRanksRestartsOnOneTwoThree) {
    const std::string common = " run " + kSource + "/jobs/scenes/magnetic-tennis.toml --collide grid --solver parallel -q"
                               " --set catoms.count=1000 --set parallel.rebalance_threshold=1.02";
    ASSERT_EQ(run(0, common + " --steps 200 --report " + path("full.json")).rc, 0);
    const Result w = run(2, common + " --steps 100 --checkpoint " + path("two.ckpt"));
    ASSERT_EQ(w.rc, 0) << w.err;
    for (int ranks : {0, 2, 3}) {
        const std::string name = "restart" + std::to_string(ranks) + ".json";
        const Result r = run(ranks, common + " --restart " + path("two.ckpt") + " --steps 100 --report " + path(name));
        ASSERT_EQ(r.rc, 0) << ranks << " ranks: " << r.err;
        EXPECT_EQ(report(name)["state_hash"], report("full.json")["state_hash"]) << "restarted on " << ranks << " ranks";
        if (ranks < 2) continue;
        const std::string at = "setup" + std::to_string(ranks) + ".json";
        ASSERT_EQ(run(ranks, common + " --restart " + path("two.ckpt") + " --steps 0 --report " + path(at)).rc, 0);
        EXPECT_EQ(report(at)["parallel"]["migrations"].get<long>(), 0) << ranks << " ranks: bodies moved at setup";
    }
}

// The report's communication figures count the steps only; setup's
// (partition, distribution, first exchange) are reported apart and do not
// depend on how many steps follow; so does the solver's exchange time.
TEST_F(Mpi, StepCommunicationExcludesSetup) {
    const std::string common = " run " + kSource + "/jobs/scenes/tennis.toml --collide grid --solver parallel -q"
                               " --set catoms.count=2000";
    for (const char* steps : {"0", "4"}) {
        const Result r = run(2, common + " --steps " + steps + " --report " + path(std::string(steps) + ".json"));
        ASSERT_EQ(r.rc, 0) << r.err;
    }
    const nlohmann::json none = report("0.json")["parallel"], four = report("4.json")["parallel"];
    EXPECT_EQ(none["comm_bytes"].get<long>(), 0);
    EXPECT_EQ(none["messages_per_step"].get<double>(), 0.0);
    EXPECT_GT(none["setup_comm_bytes"].get<long>(), 2000 * 8) << "setup sends every body's state";
    EXPECT_EQ(four["setup_comm_bytes"], none["setup_comm_bytes"]);
    EXPECT_GT(four["comm_bytes"].get<long>(), 0);
    // The solver's time exchanging corrections between colours, per process.
    EXPECT_EQ(none["solver_exchange_seconds"]["max"].get<double>(), 0.0);
    EXPECT_GT(four["solver_exchange_seconds"]["min"].get<double>(), 0.0);
    // Each rank walks its neighbour list in id order, so every merge of a
    // call the list served (built or reused) needs no sort; only a call of
    // the grid alone (after a list that lasted under two calls) sorts.
    const nlohmann::json counts = report("4.json")["collide_counts"];
    const long listed = counts["neighbour_list_builds"].get<long>() + counts["neighbour_list_uses"].get<long>();
    EXPECT_GE(listed, 2 * 3) << counts.dump();
    EXPECT_GE(counts["merges_in_order"].get<long>(), listed) << counts.dump();
}

// PARODE_INJECT_LATENCY_US holds every exchange until that long after it
// began: at 1 ms the solver's 168 exchanges a step wait about 168 ms a step
// (the few interior cells of 1,000 catoms hide nearly nothing), without it
// a few; the state is the same bit for bit; a bad value stops the run (2).
TEST_F(Mpi, InjectedLatencyDelaysEveryExchangeAndChangesNoBit) {
    const std::string common = " run " + kSource + "/jobs/scenes/tennis.toml --collide grid --solver parallel -q"
                               " --set catoms.count=1000 --steps 3 --threads 1";
    ASSERT_EQ(run(2, common + " --report " + path("none.json")).rc, 0);
    const Result slow = run(2, common + " --report " + path("slow.json"), 240, "PARODE_INJECT_LATENCY_US=1000");
    ASSERT_EQ(slow.rc, 0) << slow.err;
    const nlohmann::json none = report("none.json"), late = report("slow.json");
    EXPECT_EQ(late["state_hash"], none["state_hash"]);
    EXPECT_EQ(late["parallel"]["injected_latency_us"].get<double>(), 1000.0);
    const double waited = late["parallel"]["wait_seconds"]["min"].get<double>();
    EXPECT_GT(waited, 0.8 * 3 * 168 * 1e-3) << "every colour's exchange held about 1 ms";
    EXPECT_LT(none["parallel"]["wait_seconds"]["max"].get<double>(), 0.5 * waited);
    const Result bad = run(2, common, 240, "PARODE_INJECT_LATENCY_US=soon");
    EXPECT_EQ(bad.rc, 2) << bad.err;
    EXPECT_NE(bad.err.find("PARODE_INJECT_LATENCY_US=soon: expected microseconds"), std::string::npos) << bad.err;
}

// Memory per rank follows what the rank holds, not the machine: with 50,000
// catoms a rank on 2, 4 and 8 ranks, the fullest rank's peak memory per body
// it holds (owned ones and ghost copies, as the report's memory.fullest
// counts them on that rank) stays within 5 %. A rank keeps no
// table of the whole scene (the cell map is of blocks past 4 million cells,
// partition.hpp); what grows with more ranks is the ghost copies of more
// faces, which the measure counts. Huge pages are off here: whether the
// kernel has a free 2 MB page to give moves a rank's peak by 2 MB from run to
// run (util/huge_pages.hpp), which is the kernel's state, not the rank's.
class MpiMemory : public Mpi {
protected:
    // The peak bytes per held body on 2, 4 and 8 ranks (`extra`: more options).
    std::vector<double> bytes_per_held_body(const std::string& extra) const;
};

std::vector<double> MpiMemory::bytes_per_held_body(const std::string& extra) const {
    std::vector<double> per_body;
    for (int ranks : {2, 4, 8}) {
        const std::string name = "mem" + std::to_string(ranks) + ".json";
        const Result r = run(ranks, " run " + kSource + "/jobs/scenes/tennis.toml --collide grid --solver parallel -q"
                                    " --steps 1 --threads 1 --set catoms.count=" + std::to_string(50000 * ranks) +
                                    " --report " + path(name) + extra, 240, "PARODE_HUGE_PAGES=0");
        EXPECT_EQ(r.rc, 0) << r.err;
        if (r.rc != 0) return per_body;
        const nlohmann::json j = report(name), fullest = j["memory"]["fullest"];
        EXPECT_GE(fullest["rank"].get<int>(), 0);
        EXPECT_LT(fullest["rank"].get<int>(), ranks);
        const double owned = fullest["owned"].get<double>(), held = owned + fullest["ghosts"].get<double>();
        EXPECT_NEAR(owned, 50000.0, 0.05 * 50000.0) << "the partition's balance: " << ranks << " ranks";
        EXPECT_NEAR(held / owned - 1.0, j["parallel"]["ghost_fraction"].get<double>(), 0.1) << ranks << " ranks";
        std::int64_t parts = 0;  // the fullest rank's peak in parts (memory.peak_by_stage)
        for (const auto& part : j["memory"]["peak_by_stage"]) parts += part.get<std::int64_t>();
        EXPECT_EQ(parts, j["memory"]["peak_rss_bytes"]["max"].get<std::int64_t>()) << ranks << " ranks";
        per_body.push_back(j["memory"]["peak_rss_bytes"]["max"].get<double>() / held);
    }
    return per_body;
}

// The largest of the three within 5 % of the least.
void expect_within_five_percent(const std::vector<double>& per_body) {
    ASSERT_EQ(per_body.size(), 3u);
    const auto [least, most] = std::minmax_element(per_body.begin(), per_body.end());
    EXPECT_LE(*most / *least, 1.05) << "bytes per held body on 2, 4, 8 ranks: " << per_body[0] << ", " << per_body[1]
                                    << ", " << per_body[2];
}

TEST_F(MpiMemory, PerRankFollowsWhatTheRankHolds) { expect_within_five_percent(bytes_per_held_body("")); }

// The same with a catom program on every catom: the program pass keeps its
// bookkeeping for the catoms a rank holds, none for the rest of the scene
// (at 8 ranks the scene's other 350,000 catoms would add 7 %).
TEST_F(MpiMemory, WithProgramsPerRankFollowsWhatTheRankHolds) {
    expect_within_five_percent(bytes_per_held_body(" --program gradient"));
}

// Trajectory and snapshot files from 2 processes equal the one-process files, byte for byte.
TEST_F(Mpi, OutputFilesEqualOneProcessFiles) {
    const std::string common = " run " + kSource + "/jobs/scenes/magnetic-tennis.toml --steps 60 --collide grid"
                               " --solver parallel -q --set catoms.count=500 --snapshot-every 20";
    ASSERT_EQ(run(0, common + " --trajectory " + path("a.traj") + " --snapshot " + path("a.csv")).rc, 0);
    const Result r = run(2, common + " --trajectory " + path("b.traj") + " --snapshot " + path("b.csv"));
    ASSERT_EQ(r.rc, 0) << r.err;
    EXPECT_EQ(slurp(dir_ / "a.csv"), slurp(dir_ / "b.csv"));
    EXPECT_GT(slurp(dir_ / "a.traj").size(), 60u * 500u * 24u / 10u);
    EXPECT_EQ(slurp(dir_ / "a.traj"), slurp(dir_ / "b.traj"));
}

// The guard fires on the process that owns the fast body; every process
// stops at the same step with exit 1, one message, the same dump file.
TEST_F(Mpi, GuardStopsEveryProcessWithOneMessage) {
    const std::string common = " run " + kSource + "/tests/data/mpi/fast_body.toml --collide grid --solver parallel -q";
    const Result one = run(0, common + " --dump-on-failure " + path("one.csv"));
    ASSERT_EQ(one.rc, 1) << one.err;
    const Result two = run(2, common + " --dump-on-failure " + path("two.csv"));
    EXPECT_EQ(two.rc, 1) << two.err;
    EXPECT_EQ(count(two.err, "faster than guard.max_speed"), 1u) << two.err;
    EXPECT_NE(two.err.find("fastest: 0 ("), std::string::npos) << "names the body: " << two.err;
    EXPECT_EQ(slurp(dir_ / "one.csv"), slurp(dir_ / "two.csv"));
}

TEST_F(Mpi, JointedSceneIsRefusedWithTheReason) {
    const Result r = run(2, " run " + kSource + "/jobs/scenes/buggy.toml --solver parallel -q");
    EXPECT_EQ(r.rc, 3) << r.err;
    EXPECT_EQ(count(r.err, "has joints"), 1u) << "one message, from the root: " << r.err;
    EXPECT_NE(r.err.find("without mpirun"), std::string::npos) << r.err;
}

TEST_F(Mpi, OdeStepperIsRefusedWithTheReason) {
    const Result r = run(2, " run " + kSource + "/jobs/scenes/tennis.toml --solver ode --set catoms.count=64 -q");
    EXPECT_EQ(r.rc, 2) << r.err;
    EXPECT_NE(r.err.find("use --solver parallel"), std::string::npos) << r.err;
}

TEST_F(Mpi, MagnetReachPastTheHaloIsRefused) {
    const Result r = run(2, " run " + kSource + "/jobs/scenes/magnetic-tennis.toml --solver parallel -q"
                            " --set catoms.count=64 --set magnets.cutoff=1.5");
    EXPECT_EQ(r.rc, 3) << r.err;
    EXPECT_NE(r.err.find("reaches past the ghost halo"), std::string::npos) << r.err;
}

// Only the root writes snapshots: when its disk is full, it fails alone, and
// every process must still end (through MPI_Abort), never wait forever.
TEST_F(Mpi, FailureOnOneProcessEndsAllOfThem) {
    const Result r = run(2, " run " + kSource + "/jobs/scenes/tennis.toml --collide grid --solver parallel -q"
                            " --set catoms.count=500 --steps 2000 --snapshot /dev/full --snapshot-every 1", 60);
    EXPECT_NE(r.rc, 0);
    EXPECT_NE(r.rc, 124) << "timed out: a process waited for one that had stopped";
    EXPECT_NE(r.err.find("rank 0: cannot write output: /dev/full: the snapshot could not be written"), std::string::npos) << r.err;
}

}  // namespace
