// Library entry points: drop-in replacements for dSpaceCollide / dSpaceCollide2
// for any ODE program, backed by the OpenMP engine of grid_collide.hpp.
//
// Requirement: every geom needs a unique integer id in its user data, set with
// parode::set_geom_id(geom, id) (contacts.hpp); ids should be dense (0..n-1)
// for the fastest merge. Geoms that are spaces need no id. Contacts come out in
// canonical order: by (lower id, higher id, index within the pair), each pair
// collided as dCollide(lower-id geom, higher-id geom), so the result does not
// depend on the thread count or the space type, and equals what ODE's own
// dSpaceCollide reports (after the same sort).
//
// Trade-off: the contacts are collected before any user code sees them (a
// buffer of all contacts of the call) so that the callback can be handed them
// serially and in a fixed order, e.g. to create contact joints, which ODE does
// not allow concurrently.
#pragma once
#include <ode/ode.h>

#include "collide/contacts.hpp"

namespace parode {

// Every contact of `space` (nested spaces included) into `out` (overwritten).
// `threads` = 0 uses OMP_NUM_THREADS / omp_get_max_threads().
void collide(dSpaceID space, int max_contacts, ContactBuffer& out, int threads = 0);

// `geom` (a geom, or a small space) against `space`, as dSpaceCollide2 does.
void collide2(dGeomID geom, dSpaceID space, int max_contacts, ContactBuffer& out, int threads = 0);

// Called once per touching pair, serially, in canonical order: g1 has the lower
// id, `contacts[0..count)` are exactly what dCollide(g1, g2, ...) wrote.
using ContactPairCallback = void (*)(void* data, dGeomID g1, dGeomID g2,
                                     const dContactGeom* contacts, int count);

// collide() followed by the callback over every touching pair.
void collide_space(dSpaceID space, int max_contacts, void* data, ContactPairCallback callback,
                   int threads = 0);

// collide2() followed by the callback over every touching pair.
void collide_space2(dGeomID geom, dSpaceID space, int max_contacts, void* data,
                    ContactPairCallback callback, int threads = 0);

// Adds `g` to `out`, or every geom inside it if it is a space (recursively).
void add_geoms(dGeomID g, GeomsById& out);

// Hands the pairs of an already collided buffer to `callback` (canonical
// order), the geoms looked up by id in `geoms`.
void for_each_pair(const ContactBuffer& contacts, const GeomsById& geoms, void* data, ContactPairCallback callback);

}  // namespace parode
