// The narrow phase: where two geoms (eom/multibody/scene.hpp) touch, as MuJoCo 2.2 finds it for
// the primitive pairs: plane–sphere, plane–capsule, plane–box, sphere–sphere, sphere–capsule,
// capsule–capsule, sphere–box and capsule–box (docs/CONTRACT.md §1, "Contacts between geoms"),
// MuJoCo's mjc_ functions' cases and arithmetic written anew. The same contacts, in the same
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

// The most contacts collide() gives a pair of shapes, a's not after b's (0: a pair it does not
// model): plane–box, four corners; plane–capsule, capsule–capsule and capsule–box, two.
constexpr int pair_contacts(Shape a, Shape b) {
  switch (a) {
    case Shape::plane:
      return b == Shape::sphere ? 1 : b == Shape::capsule ? 2 : b == Shape::box ? 4 : 0;
    case Shape::sphere: return b == Shape::sphere || b == Shape::capsule || b == Shape::box ? 1 : 0;
    case Shape::capsule: return b == Shape::capsule || b == Shape::box ? 2 : 0;
    default: return 0;
  }
}

// The most contacts any pair gives.
inline constexpr int max_pair_contacts = 4;

// Whether collide() models a pair of shapes, a's not after b's.
constexpr bool collides(Shape a, Shape b) { return pair_contacts(a, b) > 0; }

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

// A sphere at p (radius r) and a box of half-sizes s placed at x: 0 or 1 contact, between the
// box's point nearest the centre and the sphere's point deepest towards it, the normal from the
// sphere to the box. A centre inside the box leaves through the nearest face (the first of −x,
// +x, −y, ... on a tie), and its dist is −r whatever the depth: MuJoCo's.
inline int sphere_box(const V3& p, double r, const Transform<double>& x, const V3& s,
                      double margin, Contact* out) {
  const V3 centre = rotate_back(x.rotation, minus(p, x.translation));  // in the box's axes
  V3 nearest;
  for (int i = 0; i < 3; ++i) nearest[i] = std::clamp(centre[i], -s[i], s[i]);
  V3 normal = minus(nearest, centre);
  const double gap = normalize3(normal);
  if (gap - r > margin) return 0;
  V3 pos;
  if (gap <= 1e-15) {
    double closest = (s[0] + s[1] + s[2]) * 2;
    int face = 0;
    for (int k = 0; k < 6; ++k) {
      const double to_face = std::abs((k % 2 ? 1 : -1) * s[k / 2] - centre[k / 2]);
      if (to_face < closest) closest = to_face, face = k;
    }
    normal = {0, 0, 0};
    normal[face / 2] = face % 2 ? -1 : 1;  // into the box, away from that face
    pos = plus(centre, scaled(normal, (r - closest) / 2));
  } else {
    pos = plus(scaled(nearest, 0.5), scaled(plus(centre, scaled(normal, r)), 0.5));
  }
  out->dist = gap - r;
  out->pos = plus(rotate(x.rotation, pos), x.translation);
  out->frame = contact_frame(rotate(x.rotation, normal), {0, 0, 0});
  return 1;
}

// A capsule (centre p, unit axis a, radius r, half-length h) and a box of half-sizes s placed at
// x: 0 to 2 contacts, MuJoCo's. The segment's point nearest the box, found among its ends against
// the faces (an end outside at most one face's slab) and the segment against the twelve edges,
// gives the first, as a sphere of radius r against the box; a second sphere further along the
// segment, where the segment lies along a face or edge rather than pointing at the box, the
// farthest point still over the box (MuJoCo's heuristic, reproduced case by case).
inline int capsule_box(const V3& p, const V3& a, double r, double h, const Transform<double>& x,
                       const V3& s, double margin, Contact* out) {
  const V3 centre = rotate_back(x.rotation, minus(p, x.translation));  // in the box's axes
  const V3 axis = rotate_back(x.rotation, a), half = scaled(axis, h);
  int octant = 0;  // where `half` points: bit i set where half[i] > 0
  for (int i = 0; i < 3; ++i)
    if (half[i] > 0) octant |= 1 << i;

  // The nearest feature, by squared distance from MuJoCo's (unsquared) start: along, where on the
  // segment (−1 to 1); an end against a face, or the segment against an edge.
  double best = margin + 2 * (r + h + s[0] + s[1] + s[2]), along = 0;
  enum { none, end_on_face, on_edge } nearest = none;
  int face = -1;  // an end's: the one axis it is outside the box along (−1: inside)
  int corner = 0, edge = 0, edge_end = 1;  // on an edge: its lower corner (bits as octant), axis,
  double edge_at = 0;                      // where on it (−1 to 1; edge_end 0, 2: at an end)
  for (int end = -1; end <= 1; end += 2) {
    const V3 tip = plus(centre, scaled(half, static_cast<double>(end)));
    V3 on = tip;
    int outside = 0, last = -1;
    for (int j = 0; j < 3; ++j) {
      if (on[j] >= -s[j] && on[j] <= s[j]) continue;
      on[j] = std::clamp(on[j], -s[j], s[j]), ++outside, last = j;
    }
    if (outside > 1) continue;  // nearer an edge or corner: the edges below
    const V3 d = minus(on, tip);
    if (dot(d, d) < best) best = dot(d, d), along = end, nearest = end_on_face, face = last;
  }
  for (int j = 0; j < 3; ++j) {  // the edges along axis j, from their midpoints m
    for (int i = 0; i < 8; ++i) {
      if (i & (1 << j)) continue;
      V3 m{i & 1 ? s[0] : -s[0], i & 2 ? s[1] : -s[1], i & 4 ? s[2] : -s[2]};
      m[j] = 0;
      // The nearest points m + x1 s_j e_j and centre + x2 half, as capsule–capsule's.
      const V3 dif = minus(m, centre);
      const double ma = s[j] * s[j], mb = -s[j] * half[j], mc = h * h;
      const double u = -s[j] * dif[j], v = dot(half, dif), det = ma * mc - mb * mb;
      if (std::abs(det) < 1e-15) continue;  // parallel: the ends against the faces cover it
      const double inv = 1 / det;
      double x1 = (mc * u - mb * v) * inv, x2 = (ma * v - mb * u) * inv;
      int at = 1;  // on the edge: 0, 2 at its lower, upper corner
      if (x1 > 1) {
        x1 = 1, at = 2, x2 = (v - mb) * (1 / mc);
      } else if (x1 < -1) {
        x1 = -1, at = 0, x2 = (v + mb) * (1 / mc);
      }
      if (x2 > 1 || x2 < -1) {
        x1 = x2 > 1 ? (u - mb) * (1 / ma) : (u + mb) * (1 / ma);
        x2 = x2 > 1 ? 1 : -1;
        if (x1 > 1) {
          x1 = 1, at = 2;
        } else if (x1 < -1) {
          x1 = -1, at = 0;
        }
      }
      V3 d = minus(dif, scaled(half, x2));
      d[j] += s[j] * x1;
      if (dot(d, d) < best - 1e-15) {  // the 1e-15: MuJoCo's, against a segment along a face
        best = dot(d, d), along = x2, nearest = on_edge;
        corner = at == 2 ? i | 1 << j : i, edge = j, edge_end = at, edge_at = x1;
      }
    }
  }
  if (nearest == none) return 0;

  // The second sphere: `second` further along the segment, where there is one.
  bool two = false;
  double second = 0;
  if (nearest == on_edge && edge_end != 1) {  // at a corner: along an edge or over a face
    int side = octant ^ corner;  // the axes along which the segment leaves the corner inwards
    if (side != 0 && side != 7) {  // 0, 7: the segment points at the corner, no second
      double sign = 1, ahead = 1 - along, back = 1 + along;
      if (side == 3 || side == 5 || side == 6) side = 7 - side, sign = -1, std::swap(ahead, back);
      const int k = side == 1 ? 0 : side == 2 ? 1 : 2, k1 = (k + 1) % 3, k2 = (k + 2) % 3;
      if (axis[k] * axis[k] > 0.5) {  // along the edge, to its other corner at most
        second = sign * std::min(ahead, 2 * s[k] / std::abs(half[k]));
      } else {  // over the face, to its far side at most
        second = -sign * std::min({back, 2 * s[k1] / std::abs(half[k1]),
                                   2 * s[k2] / std::abs(half[k2])});
      }
      two = true;
    }
  } else if (nearest == on_edge) {  // across an edge (an X, not a T): over the flatter face
    const int side = (octant ^ corner) & (7 - (1 << edge));
    if (side == 1 || side == 2 || side == 4) {
      int k1 = (edge + 1) % 3, k2 = (edge + 2) % 3;
      if (std::abs(axis[k1]) > std::abs(axis[k2])) k1 = k2;
      k2 = 3 - edge - k1;
      const bool up = side & (1 << k2);
      double ahead = std::min(up ? 1 - along : 1 + along, 2 * s[k2] / std::abs(half[k2]));
      const bool same = ((octant >> edge) & 1) == ((side >> k2) & 1);
      ahead = std::min(ahead, s[edge] * (same ? 1 - edge_at : 1 + edge_at) / std::abs(half[edge]));
      second = up ? ahead : -ahead;
      two = true;
    }
  } else if (face >= 0) {  // an end over a face: towards the other end, while over the box
    const double sign = along < 0 ? 1 : -1;
    const V3 tip = plus(centre, scaled(half, -sign));
    second = 2;
    for (int i = 0; i < 3; ++i) {
      if (i == face) continue;
      for (const double bound : {s[i], -s[i]}) {
        const double reach = (bound - tip[i]) / half[i] * sign;
        if (reach > 0 && reach < second) second = reach;
      }
    }
    second *= sign;
    two = true;
  }

  auto sphere = [&](double t, Contact* c) {  // the point centre + t half, back in the world
    return sphere_box(plus(rotate(x.rotation, plus(centre, scaled(half, t))), x.translation), r,
                      x, s, margin, c);
  };
  const int n = sphere(along, out);
  return two ? n + sphere(second + along, out + n) : n;
}

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
        if (++count == 4) break;  // MuJoCo stops at four
      }
      return count;
    }
    return -1;
  }
  if (b.shape == Shape::box) {
    if (a.shape == Shape::sphere) return sphere_box(pa, a.size[0], xb, b.size, margin, out);
    if (a.shape == Shape::capsule)
      return capsule_box(pa, za, a.size[0], a.size[1], xb, b.size, margin, out);
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
