// `parode latency`: the message latency that bounds a distributed run. Under
// mpiexec -n 2 (or more) it measures the one-way latency of a ping-pong
// between ranks 0 and 1 and the time of one neighbour-exchange round (every
// process swaps a message with every other, as the contact solver does after
// each colour of each sweep, about 170 times a step), for message sizes of a
// few boundary bodies. These are the inputs of analysis/scaling_model.py.
// Trade-off: small, fixed message sizes; bandwidth-bound exchanges (ghost
// states, migration) are measured in the run report's comm_bytes/seconds.
#include <cstdio>
#include <iostream>

#include "cli_common.hpp"
#include "processes.hpp"

namespace parode::cli {

void add_latency(CLI::App& app, LatencyArgs& a, std::function<int()>& action) {
    CLI::App* l = app.add_subcommand("latency", "Measure MPI latency under mpiexec (ping-pong and exchange rounds)");
    l->add_option("--rounds", a.rounds, "Messages per measurement")->check(CLI::Range(10, 10000000))->capture_default_str();
    l->add_option("--json", a.json, "Also write the figures as JSON");
    l->callback([&] {
        action = [&] {
            const Processes& p = *Processes::current();
            if (p.size() < 2) throw std::invalid_argument("parode latency needs 2 or more MPI processes (mpiexec -n 2 parode latency)");
            nlohmann::json j = {{"ranks", p.size()}, {"rounds", a.rounds}};
            for (std::size_t bytes : {8u, 56u * 16u, 56u * 256u, 56u * 4096u}) {
                const auto [ping, round] = p.latency(a.rounds, bytes);
                j["bytes"].push_back(bytes);
                j["ping_pong_s"].push_back(ping);
                j["exchange_round_s"].push_back(round);
                if (p.root()) {
                    std::printf("%8zu bytes: ping-pong %.2f us one way, exchange round %.2f us\n", bytes, 1e6 * ping, 1e6 * round);
                }
            }
            if (p.root() && !a.json.empty()) write_json(a.json, j);
            return 0;
        };
    });
}

}  // namespace parode::cli
