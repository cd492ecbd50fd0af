// The narrow phase: where two geoms (eom/multibody/scene.hpp) touch, as MuJoCo 2.2 finds it for
// the primitive pairs: plane–sphere, plane–capsule, plane–box, sphere–sphere, sphere–capsule and
// capsule–capsule (docs/CONTRACT.md §1, "Contacts between geoms"). The same contacts, in the same
// order, with the same conventions, so that a simulation built on them can be checked against
// MuJoCo's contact by contact. In double: the runtime's reference for the simulation to come.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "eom/multibody/scene.hpp"
#include "eom/multibody/spatial.hpp"
#include "eom/multibody/tree.hpp"

namespace eom {

// A contact point of two geoms, MuJoCo's mjContact: dist, the signed distance between their
// surfaces (negative: penetration); pos, midway between them, world; frame, three rows (world
// axes): the normal, pointing from the first geom into the second, then two tangents (MuJoCo's
// mju_makeFrame: the first along a capsule's axis where a plane meets a capsule, else along y,
// or z where the normal is near y; the second the normal × the first).
struct Contact {
  double dist = 0;
  std::array<double, 3> pos{0, 0, 0};
  std::array<double, 9> frame{1, 0, 0, 0, 1, 0, 0, 0, 1};
};

// The most contacts one pair gives (plane–box: four corners).
inline constexpr int max_pair_contacts = 4;

// Whether collide() models a pair of shapes, a's not after b's.
constexpr bool collides(Shape a, Shape b) {
  switch (a) {
    case Shape::plane: return b == Shape::sphere || b == Shape::capsule || b == Shape::box;
    case Shape::sphere: return b == Shape::sphere || b == Shape::capsule;
    case Shape::capsule: return b == Shape::capsule;
    default: return false;
  }
}

namespace detail {

// Vectors in double, with the tree's helpers (eom/multibody/tree.hpp: plus, minus, scaled, dot,
// cross), whose operations and their order are MuJoCo's mju_ functions': contacts agree to the
// last bits.
using V3 = Vec3<double>;
// a / |a| and |a|; (1, 0, 0) where |a| < 1e-15 (MuJoCo's mjMINVAL), as mju_normalize3.
inline double normalize3(V3& a) {
  const double n = std::sqrt(dot(a, a));
  if (n < 1e-15) {
    a = {1, 0, 0};
  } else {
    const double inv = 1 / n;
    a = scaled(a, inv);
  }
  return n;
}
inline V3 z_axis(const Transform<double>& x) {  // column 2 of the rotation
  return {x.rotation[6], x.rotation[7], x.rotation[8]};
}

// The contact frame from its normal and a hint for the first tangent (zero: none).
inline std::array<double, 9> contact_frame(V3 normal, V3 hint) {
  normalize3(normal);
  if (std::sqrt(dot(hint, hint)) < 0.5)
    hint = normal[1] < 0.5 && normal[1] > -0.5 ? V3{0, 1, 0} : V3{0, 0, 1};
  V3 t = minus(hint, scaled(normal, dot(normal, hint)));
  normalize3(t);
  const V3 b = cross(normal, t);
  return {normal[0], normal[1], normal[2], t[0], t[1], t[2], b[0], b[1], b[2]};
}

// A sphere at p1 (radius r1, axes z1) and one at p2 (r2, z2): 0 or 1 contact.
inline int sphere_sphere(const V3& p1, double r1, const V3& z1, const V3& p2, double r2,
                         const V3& z2, double margin, Contact* out) {
  V3 normal = minus(p2, p1);
  const double centres = std::sqrt(dot(normal, normal));
  if (centres > margin + r1 + r2) return 0;
  out->dist = centres - r1 - r2;
  if (normalize3(normal) < 1e-15) {  // concentric: across both z axes ((1, 0, 0) if parallel)
    normal = cross(z1, z2);
    normalize3(normal);
  }
  out->pos = plus(p1, scaled(normal, r1 + out->dist / 2));
  out->frame = contact_frame(normal, {0, 0, 0});
  return 1;
}

// A plane (normal n through o) and a sphere at p, radius r: 0 or 1 contact.
inline int plane_sphere(const V3& o, const V3& n, const V3& p, double r, double margin,
                        const V3& hint, Contact* out) {
  const double centre = dot(minus(p, o), n);
  if (centre > margin + r) return 0;
  out->dist = centre - r;
  out->pos = plus(p, scaled(n, -out->dist / 2 - r));
  out->frame = contact_frame(n, hint);
  return 1;
}

inline double clamp_unit(double x) { return std::clamp(x, -1.0, 1.0); }

}  // namespace detail

// The contacts of geoms a and b (a's shape not after b's), placed at xa and xb in the world,
// within margin: their count (at most max_pair_contacts), written to out in MuJoCo's order; −1
// for a pair of shapes collides() does not model.
inline int collide(const Geom& a, const Transform<double>& xa, const Geom& b,
                   const Transform<double>& xb, double margin, Contact* out) {
  using namespace detail;
  const V3 pa = xa.translation, pb = xb.translation, za = z_axis(xa), zb = z_axis(xb);
  if (a.shape == Shape::plane) {
    if (b.shape == Shape::sphere) return plane_sphere(pa, za, pb, b.size[0], margin, {0, 0, 0}, out);
    if (b.shape == Shape::capsule) {  // its two end spheres, the tangent along its axis
      const V3 half = scaled(zb, b.size[1]);
      const int n = plane_sphere(pa, za, plus(pb, half), b.size[0], margin, zb, out);
      return n + plane_sphere(pa, za, minus(pb, half), b.size[0], margin, zb, out + n);
    }
    if (b.shape == Shape::box) {  // the corners within margin below the box's centre, four at most
      const double centre = dot(minus(pb, pa), za);
      int count = 0;
      for (int i = 0; i < 8; ++i) {
        const V3 local{i & 1 ? b.size[0] : -b.size[0], i & 2 ? b.size[1] : -b.size[1],
                       i & 4 ? b.size[2] : -b.size[2]};
        const V3 corner = rotate(xb.rotation, local);
        const double below = dot(za, corner);
        if (centre + below > margin || below > 0) continue;
        Contact& c = out[count];
        c.dist = centre + below;
        c.pos = plus(plus(corner, pb), scaled(za, -c.dist / 2));
        c.frame = contact_frame(za, {0, 0, 0});
        if (++count == max_pair_contacts) break;
      }
      return count;
    }
    return -1;
  }
  if (a.shape == Shape::sphere && b.shape == Shape::sphere)
    return sphere_sphere(pa, a.size[0], za, pb, b.size[0], zb, margin, out);
  if (a.shape == Shape::sphere && b.shape == Shape::capsule) {  // the axis's nearest point
    const V3 axis = scaled(zb, b.size[1]);
    const double x = clamp_unit(dot(axis, minus(pa, pb)) / dot(axis, axis));
    return sphere_sphere(pa, a.size[0], za, plus(pb, scaled(axis, x)), b.size[0], zb, margin, out);
  }
  if (a.shape == Shape::capsule && b.shape == Shape::capsule) {
    // The segments' nearest points p1 + x1 a1, p2 + x2 a2 (x in [−1, 1]); parallel segments: up
    // to two contacts, from each end of the first and then of the second.
    const V3 a1 = scaled(za, a.size[1]), a2 = scaled(zb, b.size[1]), d = minus(pa, pb);
    const double ma = dot(a1, a1), mb = -dot(a1, a2), mc = dot(a2, a2);
    const double u = -dot(a1, d), v = dot(a2, d), det = ma * mc - mb * mb;
    auto touch = [&](double x1, double x2, Contact* c) {
      return sphere_sphere(plus(pa, scaled(a1, x1)), a.size[0], za, plus(pb, scaled(a2, x2)),
                           b.size[0], zb, margin, c);
    };
    if (std::abs(det) >= 1e-15) {
      double x1 = (mc * u - mb * v) / det, x2 = (ma * v - mb * u) / det;
      if (x1 > 1) {
        x1 = 1, x2 = (v - mb) / mc;
      } else if (x1 < -1) {
        x1 = -1, x2 = (v + mb) / mc;
      }
      if (x2 > 1) {
        x2 = 1, x1 = clamp_unit((u - mb) / ma);
      } else if (x2 < -1) {
        x2 = -1, x1 = clamp_unit((u + mb) / ma);
      }
      return touch(x1, x2, out);
    }
    int n = touch(1, clamp_unit((v - mb) / mc), out);
    n += touch(-1, clamp_unit((v + mb) / mc), out + n);
    if (n >= 2) return n;
    n += touch(clamp_unit((u - mb) / ma), 1, out + n);
    if (n >= 2) return n;
    return n + touch(clamp_unit((u + mb) / ma), -1, out + n);
  }
  return -1;
}

}  // namespace eom
