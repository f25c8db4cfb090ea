// Generators that expand compact scene tables into bodies: the catom prism
// ([catoms]) and the magnet layout ([magnets]). Also the seeded RNG used for
// jitter: SplitMix64, portable across standard libraries.
// Trade-off: a generated body is an ordinary BodySpec, so everything downstream
// treats hand-written and generated bodies alike (at ~200 bytes per body).
#pragma once
#include <cstdint>

#include "scene/scene.hpp"
#include "scene/toml_reader.hpp"

namespace parode {

class SplitMix64 {
public:
    explicit SplitMix64(std::uint64_t seed) : s_(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ULL);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
        return z ^ (z >> 31);
    }
    double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  // [0, 1)

private:
    std::uint64_t s_;
};

// Prism dimensions for `count` catoms: nx = ny = ceil(cbrt(count)), nz layers.
void prism_dims(long count, long dims[3]);

void read_catoms(const Node& root, Scene& sc);
void read_magnets(const Node& root, Scene& sc);

bool joint_param_known(const std::string& name);
std::string joint_param_names();
int joint_param_code(const std::string& name);  // -1 when unknown

}  // namespace parode
