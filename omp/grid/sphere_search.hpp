// The neighbour list build's pair search (neighbour_build.cpp): the listed
// spheres in cell order as columns (float reference centre and radius, walk
// position, cell key), and one sphere's partners among the spheres after it
// in its cell and in the half stencil's forward cells.
// A sphere meets about eighteen candidates in five short spans (two to five
// each), so a loop over each span's candidates mispredicts its exit about
// once a span. Where AVX2 is there, each span is instead tested eight
// candidates at a time, lanes past its end masked off, and the partners kept
// are packed into the list with one permute: a fixed number of steps per
// span, the same floats compared in the same order as the scalar loop, so the
// same pairs in the same order.
// Trade-off: columns padded by eight entries (read, never kept) and 8 KB of
// permute table; the search at 10^6 catoms on 2 threads took 23-25 ms
// against 31-36 for the scalar loop over a float4 per sphere.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "omp/grid/cell_grid.hpp"
#include "omp/grid/neighbour_list.hpp"

namespace parode::omp {

// Left uninitialised when a vector of them grows: every element is written
// before it is read.
template <class T>
struct Raw {
    Raw() {}
    T v;
};

// Relative slack of the build's float distance test: its rounding (a few
// units of 2^-24 in the squared distance and the squared reach) stays far
// inside it, so the list is a superset of the pairs the exact test needs.
constexpr float kFloatSlack = 1 + 1e-5f;

// The listed spheres in cell order, as the pair search reads them (28 bytes
// a sphere, against the grid's 112-byte entry and prim). Each column holds
// kPad entries more than size(), zeros, that the search may read.
struct CellSpheres {
    static constexpr std::size_t kPad = 8;
    std::vector<Raw<float>> x, y, z, r;  // reference centre, radius rounded up
    std::vector<Raw<std::uint32_t>> walk;
    std::vector<Raw<std::uint64_t>> key;
    std::size_t size() const { return key.size(); }
    // Room for n spheres (and the padding, written here).
    void resize(std::size_t n);
};

// One task's share of the pairs: each sphere's partners with a later walk
// position, sphere after sphere in cell order (own[0, kept); own is longer
// while the search goes on, and cut to `kept` after it), and the pairs whose
// other sphere comes first in the walk (lower << 32 | higher walk position).
struct Found {
    std::vector<ListEntry> own;
    std::size_t kept = 0;
    std::vector<std::uint64_t> spilled;
    // Where the next kept pairs go, with room for `more` of them (the list
    // grows by doubling: resizing it at every sphere was a call a sphere).
    ListEntry* room(std::size_t more) {
        if (own.size() < kept + more) own.resize(std::max(2 * own.size(), kept + more));
        return own.data() + kept;
    }
};

// Sphere a's pairs with the spheres after it in its cell and in the forward
// cells of the half stencil (grid_pairs.hpp) whose reference centres lie
// within the sum of the radii plus `need`: a later walk position is kept
// in out.own, an earlier one appended to out.spilled. Returns how many it kept.
// With `simd` and an AVX2 machine (avx2_search()), eight candidates at a
// time; otherwise the scalar loop. Both give the same lists (tests compare).
std::uint32_t partners(const CellGrid& g, const CellSpheres& c, std::size_t a, float need, Found& out, bool simd);

// Whether this build and machine have the AVX2 search.
bool avx2_search();

}  // namespace parode::omp
