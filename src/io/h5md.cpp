// The H5MD snapshot writer (see h5md.hpp for the layout).
#include "io/h5md.hpp"

#include <ode/ode.h>

#include <array>
#include <chrono>
#include <cstdlib>
#include <filesystem>

#include "domain/gather.hpp"
#include "io/h5_file.hpp"
#include "io/static_geometry.hpp"
#include "programs/program.hpp"
#include "io/xdmf.hpp"

#ifndef PARODE_VERSION
#define PARODE_VERSION "unknown"
#endif

namespace parode {
namespace {

using h5::Type;

// The time-dependent elements: the three of a state row, then the body x
// axis (derived from the orientation, for viewers: single precision).
struct Element {
    const char* name;
    int dims;
    Type type;
    const char* unit;
};
constexpr std::array<Element, 4> kElements{{{"position", 3, Type::F64, "m"},
                                            {"velocity", 3, Type::F64, "m s-1"},
                                            {"orientation", 4, Type::F64, ""},
                                            {"x_axis", 3, Type::F32, ""}}};
constexpr int kRow = 10;  // position, velocity, orientation
constexpr std::size_t kXAxis = 3;
// The XDMF is rewritten whole (one grid a frame): at most this often while
// the run goes on, and at the end.
constexpr int kXdmfSeconds = 10;

// A row: the state (kRow doubles), then the catom program's values.
void state_row(const World& world, std::size_t i, double* out, std::size_t values) {
    const dReal* p = dBodyGetPosition(world.body(i));
    const dReal* v = dBodyGetLinearVel(world.body(i));
    const dReal* q = dBodyGetQuaternion(world.body(i));
    for (int k = 0; k < 3; ++k) out[k] = p[k];
    for (int k = 0; k < 3; ++k) out[3 + k] = v[k];
    for (int k = 0; k < 4; ++k) out[6 + k] = q[k];
    for (std::size_t k = 0; k < values; ++k) out[kRow + k] = world.program_value(i, static_cast<int>(k));
}

// Columns [at, at + d) of `count` rows of `width` doubles, contiguous.
void columns(const std::vector<double>& rows, std::size_t count, std::size_t width, int at, int d,
             std::vector<double>& out) {
    const std::size_t w = static_cast<std::size_t>(d);
    out.resize(count * w);
    for (std::size_t k = 0; k < count; ++k) {
        for (std::size_t c = 0; c < w; ++c) out[k * w + c] = rows[k * width + static_cast<std::size_t>(at) + c];
    }
}

// The body x axis of each row's quaternion.
void x_axes(const std::vector<double>& rows, std::size_t count, std::size_t width, std::vector<float>& out) {
    out.resize(3 * count);
    for (std::size_t k = 0; k < count; ++k) {
        const double* q = rows.data() + k * width + 6;
        const Vec3 x = rotate({q[0], q[1], q[2], q[3]}, {1.0, 0.0, 0.0});
        for (std::size_t c = 0; c < 3; ++c) out[3 * k + c] = static_cast<float>(x[c]);
    }
}

const BodySpec& spec_of(const Scene& scene, std::size_t gid) {
    return gid < scene.bodies.size() ? scene.bodies[gid] : scene.catoms.proto;
}

std::int64_t species(const BodySpec& b) { return b.catom ? 0 : 1 + static_cast<std::int64_t>(b.shape.kind); }

// The bodies' bounding spheres at the current state and the static geoms.
Extent scene_extent(const Scene& scene, const World& world, const Collectives& domain) {
    Extent e = statics_extent(scene);
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (world.ghost(i)) continue;
        const dReal* p = dBodyGetPosition(world.body(i));
        e.add({p[0], p[1], p[2]}, bounding_radius(spec_of(scene, world.gid(i)).shape));
    }
    double m[6] = {-e.lo[0], -e.lo[1], -e.lo[2], e.hi[0], e.hi[1], e.hi[2]};
    domain.max(m, 6);
    if (m[0] < -m[3]) return Extent{{0, 0, 0}, {0, 0, 0}};  // nothing at all
    return Extent{{-m[0], -m[1], -m[2]}, {m[3], m[4], m[5]}};
}

class H5md final : public SnapshotWriter {
public:
    H5md(const std::string& path, const Scene& scene, const World& world, const Collectives& domain,
         std::size_t frames);
    ~H5md() override;
    void write(const World& world, long step, double time) override;
    void close() override;

private:
    void write_h5md_group();
    void write_parameters();
    void write_box(const h5::Id& group, const Extent& extent);
    void write_fixed(const h5::Id& group);
    void write_statics(const StaticMesh& mesh);
    void make_series(const h5::Id& group);
    void write_frame(std::size_t element, hsize_t frame, const void* data);
    void write_values(const std::vector<double>& rows, std::size_t values, hsize_t frame);
    void count_frame(hsize_t frame, long step, double time);
    void hold(hsize_t frames);
    // The whole of a small dataset, from the root (the others write nothing).
    void write_whole(const h5::Id& parent, const std::string& name, Type type, std::vector<hsize_t> dims, const void* data);

    const Scene& scene_;
    const Collectives& domain_;
    std::string xdmf_;
    h5::File file_;
    IdBlock block_;
    // Several processes: the values and times of `held_` frames have their
    // file space from the start (grown by doubling past it, cut to the
    // frames written at the end); 0: one process, every series grows a
    // frame at a time (SWMR keeps that safe).
    hsize_t held_ = 0;
    h5::Id step_, time_;
    std::array<h5::Id, kElements.size()> value_;
    std::vector<std::string> program_;  // the catom program's value names
    std::vector<h5::Id> program_value_;
    XdmfLayout layout_;
    std::chrono::steady_clock::time_point xdmf_written_;
};

H5md::H5md(const std::string& path, const Scene& scene, const World& world, const Collectives& domain,
           std::size_t frames)
    : scene_(scene), domain_(domain), xdmf_(xdmf_path(path)), file_(path, domain),
      block_(id_block(world.global_body_count(), domain.rank(), domain.ranks())),
      held_(file_.single() ? 0 : std::max<hsize_t>(frames, 1)) {
    const Extent extent = scene_extent(scene, world, domain);
    const StaticMesh mesh = static_mesh(scene, extent);
    write_h5md_group();
    write_parameters();
    h5::Id particles = file_.group(file_.id(), "particles");
    h5::Id all = file_.group(particles.get(), "all");
    write_box(all, extent);
    write_fixed(all);
    make_series(all);
    write_statics(mesh);
    layout_.h5 = std::filesystem::path(path).filename().string();
    layout_.bodies = world.global_body_count();
    layout_.quads = mesh.quads();
    layout_.hexes = mesh.hexes();
    file_.start_swmr();
}

H5md::~H5md() {
    try {
        close();
    } catch (const std::exception&) {  // a run that failed already reports why
    }
}

void H5md::write_h5md_group() {
    h5::Id h5md = file_.group(file_.id(), "h5md");
    file_.attribute(h5md.get(), "version", std::vector<std::int64_t>{1, 1});
    h5::Id author = file_.group(h5md.get(), "author");
    const char* user = std::getenv("USER");
    file_.attribute(author.get(), "name", from_root(domain_, user && *user ? user : "unknown"));
    h5::Id creator = file_.group(h5md.get(), "creator");
    file_.attribute(creator.get(), "name", std::string("parode"));
    file_.attribute(creator.get(), "version", std::string(PARODE_VERSION));
}

void H5md::write_parameters() {
    h5::Id p = file_.group(file_.id(), "parameters");
    file_.attribute(p.get(), "scene", scene_.name);
    file_.attribute(p.get(), "scene_file", scene_.source);
    file_.attribute(p.get(), "dt", scene_.dt);
    file_.attribute(p.get(), "seed", std::vector<std::int64_t>{static_cast<std::int64_t>(scene_.seed)});
}

void H5md::write_box(const h5::Id& group, const Extent& e) {
    h5::Id box = file_.group(group.get(), "box");
    file_.attribute(box.get(), "dimension", std::vector<std::int64_t>{3});
    file_.attribute(box.get(), "boundary", std::vector<std::string>{"none", "none", "none"});
    const double edges[3] = {e.hi[0] - e.lo[0], e.hi[1] - e.lo[1], e.hi[2] - e.lo[2]};
    write_whole(box, "edges", Type::F64, {3}, edges);
    write_whole(box, "origin", Type::F64, {3}, e.lo.data());
}

void H5md::write_fixed(const h5::Id& group) {
    std::vector<std::int64_t> id(block_.count), sp(block_.count);
    std::vector<double> mass(block_.count), radius(block_.count);
    for (std::uint64_t k = 0; k < block_.count; ++k) {
        const BodySpec& b = spec_of(scene_, block_.first + k);
        id[k] = static_cast<std::int64_t>(block_.first + k);
        sp[k] = species(b);
        mass[k] = b.mass;
        radius[k] = bounding_radius(b.shape);
    }
    const hsize_t n = scene_.body_count();
    const auto fixed = [&](const char* name, Type type, const void* data, const char* unit) {
        h5::Id d = file_.dataset(group.get(), name, type, {n});
        file_.write(d.get(), type, {block_.first}, {block_.count}, data);
        if (*unit) file_.attribute(d.get(), "unit", std::string(unit));
        return d;
    };
    fixed("id", Type::I64, id.data(), "");
    h5::Id s = fixed("species", Type::I64, sp.data(), "");
    file_.attribute(s.get(), "names", std::vector<std::string>{"catom", "sphere", "box", "capsule", "cylinder"});
    fixed("mass", Type::F64, mass.data(), "kg");
    fixed("radius", Type::F64, radius.data(), "m");
}

void H5md::make_series(const h5::Id& group) {
    const hsize_t n = scene_.body_count();
    const bool early = held_ > 0;
    for (std::size_t e = 0; e < kElements.size(); ++e) {
        h5::Id g = file_.group(group.get(), kElements[e].name);
        if (e == 0) {  // one chunk for many frames: a frame takes no file space of its own
            step_ = file_.series(g.get(), "step", Type::I64, {0}, std::max<hsize_t>(held_, 1), early);
            time_ = file_.series(g.get(), "time", Type::F64, {held_}, std::max<hsize_t>(held_, 1), early);
            file_.attribute(time_.get(), "unit", std::string("s"));
        } else {
            file_.link(step_.get(), g.get(), "step");
            file_.link(time_.get(), g.get(), "time");
        }
        value_[e] = file_.series(g.get(), "value", kElements[e].type, {held_, n, static_cast<hsize_t>(kElements[e].dims)}, 1,
                                 early);
        if (*kElements[e].unit) file_.attribute(value_[e].get(), "unit", std::string(kElements[e].unit));
    }
    // The catom program's values: program_<name>, a scalar per body [F][N].
    if (scene_.program.enabled) program_ = load_program(scene_.program.name).values;
    for (const std::string& name : program_) {
        h5::Id g = file_.group(group.get(), "program_" + name);
        file_.link(step_.get(), g.get(), "step");
        file_.link(time_.get(), g.get(), "time");
        program_value_.push_back(file_.series(g.get(), "value", Type::F64, {held_, n}, 1, early));
    }
    layout_.values = program_;
    layout_.held = held_;
}

void H5md::write_statics(const StaticMesh& mesh) {
    h5::Id parode = file_.group(file_.id(), "parode");
    h5::Id statics = file_.group(parode.get(), "statics");
    const auto cells = [&](const std::string& name, const std::vector<double>& points, hsize_t corners) {
        const hsize_t count = points.size() / (3 * corners);
        if (count == 0) return;
        std::vector<std::int64_t> ids(count * corners);
        for (std::size_t k = 0; k < ids.size(); ++k) ids[k] = static_cast<std::int64_t>(k);  // each cell its own corners
        write_whole(statics, name + "_points", Type::F64, {count * corners, 3}, points.data());
        write_whole(statics, name + "_cells", Type::I64, {count, corners}, ids.data());
    };
    cells("planes", mesh.quad_points, 4);
    cells("boxes", mesh.hex_points, 8);
}

void H5md::write_whole(const h5::Id& parent, const std::string& name, Type type, std::vector<hsize_t> dims, const void* data) {
    h5::Id d = file_.dataset(parent.get(), name, type, dims);
    if (!domain_.root()) dims[0] = 0;
    file_.write(d.get(), type, std::vector<hsize_t>(dims.size(), 0), dims, data);
}

// The values and the time first, then the step: its length is the number of
// complete frames whenever the file is read. One process grows every series
// by the frame and flushes in SWMR mode, which orders the metadata's writes.
// Several write a frame into space taken before (only the step's extent
// changes, after every process has written its block), then flush. The XDMF
// (at most every kXdmfSeconds) lists the frames on the disk.
void H5md::write(const World& world, long step, double time) {
    const std::size_t values = program_.size(), width = kRow + values;
    const auto row = [&world, values](std::size_t i, double* out) { state_row(world, i, out, values); };
    const std::vector<double> rows = block_rows(domain_, world, static_cast<int>(width), row);
    const hsize_t f = layout_.steps.size();
    if (held_ && f == held_) hold(2 * held_);
    write_values(rows, values, f);
    count_frame(f, step, time);
    layout_.steps.push_back(step);
    layout_.times.push_back(time);
    const auto now = std::chrono::steady_clock::now();
    if (domain_.root() && (f == 0 || now - xdmf_written_ >= std::chrono::seconds(kXdmfSeconds))) {
        write_xdmf(xdmf_, layout_);
        xdmf_written_ = now;
    }
}

void H5md::write_values(const std::vector<double>& rows, std::size_t values, hsize_t f) {
    const std::size_t width = kRow + values;
    std::vector<double> column;
    int at = 0;
    for (std::size_t e = 0; e < kXAxis; ++e) {
        columns(rows, block_.count, width, at, kElements[e].dims, column);
        write_frame(e, f, column.data());
        at += kElements[e].dims;
    }
    std::vector<float> axes;
    x_axes(rows, block_.count, width, axes);
    write_frame(kXAxis, f, axes.data());
    for (std::size_t k = 0; k < values; ++k) {
        columns(rows, block_.count, width, kRow + static_cast<int>(k), 1, column);
        if (!held_) file_.extend(program_value_[k].get(), f + 1);
        file_.write(program_value_[k].get(), Type::F64, {f, block_.first}, {1, block_.count}, column.data());
    }
}

void H5md::count_frame(hsize_t f, long step, double time) {
    const std::int64_t s = step;
    const hsize_t one = domain_.root() ? 1 : 0;
    if (!held_) file_.extend(time_.get(), f + 1);
    file_.write(time_.get(), Type::F64, {f}, {one}, &time);
    if (held_) domain_.sum(std::int64_t{0});  // a barrier: every process's blocks are written before the count grows
    file_.extend(step_.get(), f + 1);
    file_.write(step_.get(), Type::I64, {f}, {one}, &s);
    file_.flush();
}

void H5md::write_frame(std::size_t e, hsize_t f, const void* data) {
    if (!held_) file_.extend(value_[e].get(), f + 1);
    file_.write(value_[e].get(), kElements[e].type, {f, block_.first, 0},
                {1, block_.count, static_cast<hsize_t>(kElements[e].dims)}, data);
}

// The values' and times' space for `frames` frames (several processes).
// Growing past the planned frames takes new space and changes the chunk
// index, flushed before the next frame counts; only then could a kill during
// that flush leave the index half written.
void H5md::hold(hsize_t frames) {
    for (h5::Id& v : value_) file_.extend(v.get(), frames);
    for (h5::Id& v : program_value_) file_.extend(v.get(), frames);
    file_.extend(time_.get(), frames);
    held_ = frames;
    layout_.held = frames;
    file_.flush();
}

void H5md::close() {
    if (file_.id() < 0) return;
    if (held_ && held_ != layout_.steps.size()) hold(layout_.steps.size());  // a run that stopped early
    step_.reset();
    time_.reset();
    for (h5::Id& v : value_) v.reset();
    for (h5::Id& v : program_value_) v.reset();
    file_.close();
    if (domain_.root()) write_xdmf(xdmf_, layout_);
}

}  // namespace

std::unique_ptr<SnapshotWriter> make_h5md_writer(const std::string& path, const Scene& scene, const World& world,
                                                 const Collectives& domain, std::size_t frames) {
    return std::make_unique<H5md>(path, scene, world, domain, frames);
}

std::string h5md_library() {
    unsigned major = 0, minor = 0, release = 0;
    H5get_libversion(&major, &minor, &release);
    std::string v = std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(release);
#ifdef H5_HAVE_PARALLEL
    return v + " parallel";
#else
    return v + " serial";
#endif
}

}  // namespace parode
