// Lookups of present ids in random order in an IdMap holding HELD of 8 x HELD ids:
// the best of 7 passes over 4 M queries. Build against a tree: g++ -O3 -std=c++17 -I<tree>/src bench.cpp
#include "util/id_map.hpp"
#include <chrono>
#include <cstdio>
#include <random>
using namespace parode;
int main(int argc, char** argv) {
    const std::uint32_t held = std::atoi(argv[1]);
    IdMap m; m.reset(8ull * held, held);
    std::vector<std::uint32_t> ids(held);
    std::mt19937 r(1);
    for (std::uint32_t i = 0; i < held; ++i) { ids[i] = i * 8 + r() % 8; m.set(ids[i], i); }
    std::vector<std::uint32_t> q(1 << 22);
    for (auto& x : q) x = ids[r() % held];
    double best = 1e9; std::uint64_t s = 0;
    for (int rep = 0; rep < 7; ++rep) {
        auto t0 = std::chrono::steady_clock::now();
        for (auto x : q) s += m.find(x);
        best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::printf("%u held: %.2f ns a lookup (%llu)\n", held, best / q.size() * 1e9, (unsigned long long)(s & 1));
}
