// Static geometry for viewers (see static_geometry.hpp).
#include "io/static_geometry.hpp"

#include <algorithm>
#include <cmath>

namespace parode {
namespace {

Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

Vec3 scaled(const Vec3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }

Vec3 unit(const Vec3& a) { return scaled(a, 1.0 / std::sqrt(dot(a, a))); }

void push(std::vector<double>& out, const Vec3& p) { out.insert(out.end(), p.begin(), p.end()); }

// Two unit vectors spanning the plane of normal n, (u, v, n) right-handed.
std::pair<Vec3, Vec3> plane_axes(const Vec3& n) {
    const Vec3 other = std::abs(n[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    const Vec3 u = unit(cross(other, n));
    return {u, cross(n, u)};
}

void add_quad(std::vector<double>& out, const PlaneSpec& p, const Extent& e) {
    const double len = std::sqrt(dot(p.normal, p.normal));
    const Vec3 n = scaled(p.normal, 1.0 / len);
    const Vec3 c{0.5 * (e.lo[0] + e.hi[0]), 0.5 * (e.lo[1] + e.hi[1]), 0.5 * (e.lo[2] + e.hi[2])};
    const Vec3 d{e.hi[0] - e.lo[0], e.hi[1] - e.lo[1], e.hi[2] - e.lo[2]};
    const double half = 0.5 * std::max(4.0 * std::sqrt(dot(d, d)), 10.0);
    const Vec3 on = scaled(n, p.offset / len - dot(n, c));  // from c onto the plane
    const auto [u, v] = plane_axes(n);
    const double su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
    for (int k = 0; k < 4; ++k) {
        push(out, {c[0] + on[0] + half * (su[k] * u[0] + sv[k] * v[0]), c[1] + on[1] + half * (su[k] * u[1] + sv[k] * v[1]),
                   c[2] + on[2] + half * (su[k] * u[2] + sv[k] * v[2])});
    }
}

void add_hex(std::vector<double>& out, const StaticGeom& g) {
    const Vec3 h = half_size(g.shape);
    const double sx[8] = {-1, 1, 1, -1, -1, 1, 1, -1}, sy[8] = {-1, -1, 1, 1, -1, -1, 1, 1};
    for (int k = 0; k < 8; ++k) {
        const Vec3 r = rotate(g.orientation, {sx[k] * h[0], sy[k] * h[1], (k < 4 ? -1 : 1) * h[2]});
        push(out, {g.position[0] + r[0], g.position[1] + r[1], g.position[2] + r[2]});
    }
}

}  // namespace

void Extent::add(const Vec3& centre, double radius) {
    for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], centre[a] - radius);
        hi[a] = std::max(hi[a], centre[a] + radius);
    }
}

void Extent::add(const Extent& other) {
    if (other.empty()) return;
    add(other.lo, 0.0);
    add(other.hi, 0.0);
}

Vec3 half_size(const Shape& s) {
    switch (s.kind) {
        case ShapeKind::Sphere: return {s.radius, s.radius, s.radius};
        case ShapeKind::Box: return scaled(s.size, 0.5);
        case ShapeKind::Capsule: return {s.radius, s.radius, s.radius + 0.5 * s.length};
        case ShapeKind::Cylinder: break;
    }
    return {s.radius, s.radius, 0.5 * s.length};
}

Vec3 rotate(const Quat& q, const Vec3& x) {
    const Vec3 u{q[1], q[2], q[3]};
    const Vec3 t = scaled(cross(u, x), 2.0);  // x + w t + u x t
    const Vec3 ut = cross(u, t);
    return {x[0] + q[0] * t[0] + ut[0], x[1] + q[0] * t[1] + ut[1], x[2] + q[0] * t[2] + ut[2]};
}

Extent statics_extent(const Scene& scene) {
    Extent e;
    std::vector<double> corners;
    for (const StaticGeom& g : scene.statics) add_hex(corners, g);
    for (std::size_t i = 0; i + 3 <= corners.size(); i += 3) e.add({corners[i], corners[i + 1], corners[i + 2]}, 0.0);
    return e;
}

StaticMesh static_mesh(const Scene& scene, const Extent& extent) {
    StaticMesh m;
    for (const PlaneSpec& p : scene.planes) add_quad(m.quad_points, p, extent);
    for (const StaticGeom& g : scene.statics) add_hex(m.hex_points, g);
    return m;
}

}  // namespace parode
