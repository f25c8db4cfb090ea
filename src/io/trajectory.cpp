// Trajectory files (see trajectory.hpp).
#include "io/trajectory.hpp"

#include <fstream>
#include <stdexcept>

#include "domain/gather.hpp"

namespace parode {
namespace {

const char* kMagic = "parode-trajectory 1 ";

void pack_header(const Frame& f, double* h) {
    const double v[kFrameHeader] = {static_cast<double>(f.step), f.time, f.kinetic, f.potential,
                                    f.momentum[0], f.momentum[1], f.momentum[2],
                                    f.angular_momentum[0], f.angular_momentum[1], f.angular_momentum[2],
                                    f.com_height, f.max_penetration, f.mean_penetration, f.contacts, f.disabled, 0.0};
    for (int i = 0; i < kFrameHeader; ++i) h[i] = v[i];
}

void unpack_header(const double* h, Frame& f) {
    f.step = static_cast<long>(h[0]);
    f.time = h[1];
    f.kinetic = h[2];
    f.potential = h[3];
    f.momentum = {h[4], h[5], h[6]};
    f.angular_momentum = {h[7], h[8], h[9]};
    f.com_height = h[10];
    f.max_penetration = h[11];
    f.mean_penetration = h[12];
    f.contacts = h[13];
    f.disabled = h[14];
}

std::string catom_mask_text(const std::vector<char>& mask) {
    std::string s(mask.size(), '0');
    for (std::size_t i = 0; i < mask.size(); ++i) if (mask[i]) s[i] = '1';
    return s;
}

}  // namespace

Trajectory make_trajectory(const Scene& scene) {
    Trajectory t;
    t.catom.reserve(scene.body_count());
    for (const BodySpec& b : scene.bodies) {
        t.catom.push_back(b.catom ? 1 : 0);
        if (b.catom) t.catom_radius = std::max(t.catom_radius, b.shape.radius);
    }
    t.catom.resize(scene.body_count(), 1);
    if (scene.catoms.count) t.catom_radius = std::max(t.catom_radius, scene.catoms.proto.shape.radius);
    t.meta = {{"scene", scene.name}, {"scene_file", scene.source}, {"seed", scene.seed}, {"dt", scene.dt},
              {"observe_every", scene.observe_every}, {"bodies", scene.body_count()},
              {"catoms", scene.catom_count()}, {"catom_radius", t.catom_radius}, {"solver", solver_json(scene.solver)}};
    return t;
}

Frame capture_frame(const World& world, const Diagnostics& d, long step, double time, const Collectives& domain) {
    Frame f;
    f.step = step;
    f.time = time;
    f.kinetic = d.kinetic;
    f.potential = d.potential;
    f.momentum = d.momentum;
    f.angular_momentum = d.angular_momentum;
    f.com_height = d.com_height;
    f.max_penetration = d.max_penetration;
    f.mean_penetration = d.mean_penetration;
    f.contacts = static_cast<double>(d.contacts);
    f.disabled = static_cast<double>(d.disabled);
    f.positions = gather_rows(domain, world, 3, [&world](std::size_t i, double* out) {
        const dReal* p = dBodyGetPosition(world.body(i));
        for (int c = 0; c < 3; ++c) out[c] = p[c];
    });
    return f;
}

void write_trajectory(const std::string& path, const Trajectory& t) {
    std::ofstream out(path, std::ios::binary);
    if (!out) throw OutputError(path + ": cannot open trajectory file for writing");
    nlohmann::json meta = t.meta;
    meta["frames"] = t.frames.size();
    meta["catom_mask"] = catom_mask_text(t.catom);
    out << kMagic << meta.dump() << '\n';
    double h[kFrameHeader];
    for (const Frame& f : t.frames) {
        pack_header(f, h);
        out.write(reinterpret_cast<const char*>(h), sizeof h);
        out.write(reinterpret_cast<const char*>(f.positions.data()),
                  static_cast<std::streamsize>(f.positions.size() * sizeof(double)));
    }
    if (!out) throw OutputError(path + ": error while writing the trajectory");
}

bool is_trajectory_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::string head(std::char_traits<char>::length(kMagic), '\0');
    return in.read(head.data(), static_cast<std::streamsize>(head.size())) && head == kMagic;
}

Trajectory read_trajectory(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot open trajectory file");
    std::string line;
    std::getline(in, line);
    const std::string magic = kMagic;
    if (line.compare(0, magic.size(), magic) != 0) {
        throw std::runtime_error(path + ": not a parode trajectory file (expected it to start with '" + magic + "')");
    }
    Trajectory t;
    try {
        t.meta = nlohmann::json::parse(line.substr(magic.size()));
    } catch (const nlohmann::json::exception& e) {
        throw std::runtime_error(path + ": bad trajectory metadata: " + e.what());
    }
    const std::string mask = t.meta.value("catom_mask", std::string());
    for (char c : mask) t.catom.push_back(c == '1' ? 1 : 0);
    t.catom_radius = t.meta.value("catom_radius", 0.0);
    const std::size_t n = t.catom.size(), frames = t.meta.value("frames", std::size_t{0});
    double h[kFrameHeader];
    for (std::size_t k = 0; k < frames; ++k) {
        Frame f;
        f.positions.resize(3 * n);
        in.read(reinterpret_cast<char*>(h), sizeof h);
        in.read(reinterpret_cast<char*>(f.positions.data()), static_cast<std::streamsize>(3 * n * sizeof(double)));
        if (!in) throw std::runtime_error(path + ": truncated trajectory (frame " + std::to_string(k) + " of " +
                                          std::to_string(frames) + ")");
        unpack_header(h, f);
        t.frames.push_back(std::move(f));
    }
    return t;
}

}  // namespace parode
