// The scene's static geometry as cells a viewer draws: each plane as a large
// finite square (a quadrilateral), each static geom (ramp, wall) as a
// hexahedron, in world coordinates; and the extent of the scene, for the
// H5MD box and the size of the squares. Boxes are exact; static spheres,
// capsules and cylinders are drawn as their oriented bounding boxes.
// Trade-off: two cell kinds that every viewer reads, rather than meshes of
// curved shapes, which parode's scenes (floors and ramps) do not need.
#pragma once
#include <vector>

#include "scene/scene.hpp"

namespace parode {

struct Extent {
    Vec3 lo{1e300, 1e300, 1e300};
    Vec3 hi{-1e300, -1e300, -1e300};
    bool empty() const { return lo[0] > hi[0]; }
    void add(const Vec3& centre, double radius);
    void add(const Extent& other);
};

struct StaticMesh {
    std::vector<double> quad_points;  // 4 points (x, y, z) per plane, counter-clockwise about its normal
    std::vector<double> hex_points;   // 8 points per static geom, in VTK's hexahedron order
    std::size_t quads() const { return quad_points.size() / 12; }
    std::size_t hexes() const { return hex_points.size() / 24; }
};

// The bounding box of the static geoms (planes are infinite and left out).
Extent statics_extent(const Scene& scene);
// Planes become squares of side max(4 x the extent's diagonal, 10 m),
// centred on the extent's centre projected onto the plane.
StaticMesh static_mesh(const Scene& scene, const Extent& extent);
// The half sizes of a shape's (oriented) bounding box.
Vec3 half_size(const Shape& shape);
// x rotated by the unit quaternion q (w, x, y, z).
Vec3 rotate(const Quat& q, const Vec3& x);

}  // namespace parode
