// The narrow phase: where two geoms (eom/multibody/scene.hpp) touch, as MuJoCo 2.2 finds it for
// the pairs it finds in closed form: plane–sphere, plane–capsule, plane–ellipsoid, plane–cylinder,
// plane–box, sphere–sphere, sphere–capsule, capsule–capsule, sphere–box, capsule–box and box–box
// (docs/CONTRACT.md §1, "Contacts between geoms"), MuJoCo's mjc_ functions' cases and arithmetic
// written anew. (The other pairs of ellipsoids, cylinders and meshes MuJoCo finds by libccd's
// iterative MPR, whose iterates are not reproduced: collides() is false for them.) The same
// contacts, in the same order, with the same conventions, so that a simulation built on them can
// be checked against MuJoCo's contact by contact. In double: the runtime's reference for the
// simulation to come.
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
// model): plane–box, four corners; plane–cylinder, four (MuJoCo's: a rim point at each end and
// two more at the nearer end); plane–capsule, capsule–capsule and capsule–box, two; box–box,
// MuJoCo's most: a parallelogram's four sides crossing a rectangle's four sides (two each),
// four corners of each inside the other (nine at most where no points coincide: an octagon's
// eight corners and the deepest corner; more where they coincide without being equal).
constexpr int pair_contacts(Shape a, Shape b) {
  switch (a) {
    case Shape::plane:
      return b == Shape::sphere || b == Shape::ellipsoid ? 1
             : b == Shape::capsule                        ? 2
             : b == Shape::box || b == Shape::cylinder    ? 4
                                                          : 0;
    case Shape::sphere: return b == Shape::sphere || b == Shape::capsule || b == Shape::box ? 1 : 0;
    case Shape::capsule: return b == Shape::capsule || b == Shape::box ? 2 : 0;
    case Shape::box: return b == Shape::box ? 24 : 0;  // MuJoCo's most (detail::box_box)
    default: return 0;
  }
}

// The most contacts any pair gives.
inline constexpr int max_pair_contacts = pair_contacts(Shape::box, Shape::box);

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

// A plane (normal n through o) and a cylinder (centre p, unit axis a, radius r, half-length h):
// 0 to 4 contacts, MuJoCo's mjc_PlaneCylinder. The rim point nearest the plane at the end nearer
// it (none within margin: no contact), the same rim point at the other end, and, where the rim's
// points a third of the way round from it on each side are within margin too, those two (an
// equilateral triangle on the rim with the first: a disk lying flat stands on three points).
// Their dist is the points' distance to the plane (the two a third of the way round: the height
// of their midpoint), pos half that back towards the plane; x_axis, the cylinder's first axis,
// gives the rim point where the axis is along the normal.
inline int plane_cylinder(const V3& o, const V3& n, const V3& p, V3 a, const V3& x_axis, double r,
                          double h, double margin, Contact* out) {
  double along = dot(n, a);
  if (along > 0) a = scaled(a, -1.0), along = -along;  // the axis towards the plane
  const double centre = dot(minus(p, o), n);
  V3 rim = minus(scaled(a, along), n);  // −n less its part along the axis: to the rim
  const double length = std::sqrt(dot(rim, rim));
  rim = length >= 1e-15 ? scaled(rim, r / length) : scaled(x_axis, r);
  const double down = dot(rim, n);
  a = scaled(a, h), along *= h;
  const std::array<double, 9> frame = contact_frame(n, {0, 0, 0});
  auto add = [&](Contact& c, double dist, const V3& at) {
    c.dist = dist;
    c.pos = plus(at, scaled(n, -dist * 0.5));
    c.frame = frame;
  };
  int count = 0;
  if (!(centre + along + down <= margin)) return 0;  // the nearest point beyond margin
  add(out[count++], centre + along + down, plus(plus(p, rim), a));
  if (centre - along + down <= margin)
    add(out[count++], centre - along + down, minus(plus(p, rim), a));
  const double third = -down * 0.5;
  if (centre + along + third <= margin) {
    V3 side = cross(rim, a);
    normalize3(side);
    side = scaled(side, r * std::sqrt(3.0) / 2);
    const double dist = centre + along + third;
    add(out[count++], dist, plus(plus(plus(p, side), a), scaled(rim, -0.5)));
    add(out[count++], dist, plus(plus(minus(p, side), a), scaled(rim, -0.5)));
  }
  return count;
}

// A plane (normal n through o) and an ellipsoid of half-sizes s placed at x: 0 or 1 contact at
// its point deepest along −n (MuJoCo's mjc_PlaneConvex with the ellipsoid's support function).
inline int plane_ellipsoid(const V3& o, const V3& n, const Transform<double>& x, const V3& s,
                           double margin, Contact* out) {
  const V3 down = rotate_back(x.rotation, scaled(n, -1.0));  // in the ellipsoid's axes
  V3 deepest{down[0] * s[0], down[1] * s[1], down[2] * s[2]};
  normalize3(deepest);
  deepest = {deepest[0] * s[0], deepest[1] * s[1], deepest[2] * s[2]};
  const V3 at = plus(rotate(x.rotation, deepest), x.translation);
  const double dist = dot(n, minus(at, o));
  if (dist > margin) return 0;
  out->dist = dist;
  out->pos = plus(at, scaled(n, -0.5 * dist));
  out->frame = contact_frame(n, {0, 0, 0});
  return 1;
}

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

// MuJoCo's turn of a box's axes that takes its face `face` (axis face % 3; its negative side
// where face ≥ 3) to +z: a signed permutation, v ↦ (sign_a v[axis_a]). Each is its own
// permutation's inverse, so that it also turns the box's half-sizes into the face's frame.
struct FaceTurn {
  std::array<int, 3> axis{0, 1, 2};
  std::array<double, 3> sign{1, 1, 1};
  V3 operator()(const V3& v) const {
    return {v[axis[0]] * sign[0], v[axis[1]] * sign[1], v[axis[2]] * sign[2]};
  }
};
inline FaceTurn face_turn(int face) {
  switch (face) {
    case 0: return {{2, 1, 0}, {-1, 1, 1}};
    case 1: return {{0, 2, 1}, {1, -1, 1}};
    case 3: return {{2, 1, 0}, {1, 1, -1}};
    case 4: return {{0, 2, 1}, {1, 1, -1}};
    case 5: return {{0, 1, 2}, {-1, 1, -1}};
    default: return {};
  }
}

// Two boxes (half-sizes s1, s2) placed at x1 and x2: MuJoCo's mjc_BoxBox, its contacts (at most
// pair_contacts(box, box)), the points that repeat one further on left out (as mj_collideGeoms
// does). The 15 separating axes (each box's 3 face normals, the 9 edge pairs' normals) give the
// least overlap (none below −margin: no contact).
// - A face's normal (of either box): the other box's corner deepest under that face, with its
//   edges within 30° of the face's plane, spans a parallelogram (or a segment or point); the
//   contacts are where its sides cross the face's rectangle's, the rectangle's corners inside it
//   and its corners inside the rectangle (the deepest always), those within margin of the face,
//   dist half their depth (MuJoCo 2.2's), normal the face's (out of box 1, into box 2).
// - An edge pair's: box 2's edge and the one beside it across the face that faces box 1 best,
//   projected along the normal onto box 1's face that faces box 2 best; the contacts are where
//   the projection's sides cross the face's rectangle's, the rectangle's corners inside it (or
//   nearest it) and box 2's four corners over the face, each with its distance to the face
//   (MuJoCo's cases and its arithmetic, the reuse of a determinant included).
inline int box_box(const Transform<double>& x1, const V3& s1, const Transform<double>& x2,
                   const V3& s2, double margin, Contact* out) {
  using M3 = std::array<V3, 3>;  // rows
  const V3 pos21 = rotate_back(x1.rotation, minus(x2.translation, x1.translation));
  const V3 pos12 = rotate_back(x2.rotation, minus(x1.translation, x2.translation));
  M3 rot, rott, rotabs;  // rot[i][j]: box 1's axis i · box 2's axis j
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double* a = &x1.rotation[3 * i];
      const double* b = &x2.rotation[3 * j];
      rot[i][j] = rott[j][i] = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
      rotabs[i][j] = std::abs(rot[i][j]);
    }
  }
  V3 plen1, plen2;  // each box's extent along the other's axes
  for (int i = 0; i < 3; ++i) {
    plen2[i] = rotabs[i][0] * s2[0] + rotabs[i][1] * s2[1] + rotabs[i][2] * s2[2];
    plen1[i] = rotabs[0][i] * s1[0] + rotabs[1][i] * s1[1] + rotabs[2][i] * s1[2];
  }

  // The separating axes. code: 0–5 box 1's face (axis, +3 on its negative side), 6–11 box 2's,
  // 12 + 3 i + j the edges along box 1's axis i and box 2's axis j.
  double least = margin;
  for (int i = 0; i < 3; ++i) least += s1[i] * 3 + s2[i] * 3;
  int code = -1, cle1 = 0, cle2 = 0;  // an edge pair's: the edges' corners' sides (bits)
  bool in = false;                    // an edge pair's: box 2 on the normal's negative side
  V3 clnorm{0, 0, 0};
  for (int i = 0; i < 3; ++i) {
    const double c1 = -std::abs(pos21[i]) + s1[i] + plen2[i];
    const double c2 = -std::abs(pos12[i]) + s2[i] + plen1[i];
    if (c1 < -margin || c2 < -margin) return 0;
    if (c1 < least) least = c1, code = i + 3 * (pos21[i] < 0);
    if (c2 < least) least = c2, code = i + 3 * (pos12[i] < 0) + 6;
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const V3& c = rott[j];  // box 2's axis j in box 1's axes; the normal: box 1's axis i × it
      V3 n = i == 0 ? V3{0, -c[2], c[1]} : i == 1 ? V3{c[2], 0, -c[0]} : V3{-c[1], c[0], 0};
      const double length = normalize3(n);
      if (length < 1e-15) continue;  // parallel edges: the faces' axes cover them
      const double along = dot(pos21, n);
      double overlap = 0;
      for (int k = 0; k < 3; ++k)
        if (k != i) overlap += s1[k] * std::abs(n[k]);
      for (int k = 0; k < 3; ++k)
        if (k != j) overlap += s2[k] * rotabs[i][3 - k - j] / length;
      overlap -= std::abs(along);
      if (overlap < -margin) return 0;
      if (overlap < least * (1 - 1e-12)) {  // a face's axis wins a tie
        least = overlap;
        cle1 = cle2 = 0;
        for (int k = 0; k < 3; ++k)
          if (k != i && ((n[k] > 0) ^ (along < 0))) cle1 += 1 << k;
        for (int k = 0; k < 3; ++k)
          if (k != j && ((rot[i][3 - k - j] > 0) ^ (along < 0) ^ ((k - j + 3) % 3 == 1)))
            cle2 += 1 << k;
        code = 12 + i * 3 + j;
        clnorm = n;
        in = along < 0;
      }
    }
  }
  if (code == -1) return 0;

  constexpr int most = pair_contacts(Shape::box, Shape::box);
  std::array<V3, most> point;  // in the face's frame, and their depths
  std::array<double, most> depth;
  int n = 0;
  // (x, y) inside a rectangle [−lx, lx] × [−ly, ly] on the face; a segment's crossings with its
  // sides: start + t dir, t in [0, 1], where x = ±lx with |y| ≤ ly or y = ±ly with |x| ≤ lx.
  auto crossings = [&](const V3& start, const V3& dir, const V3& size, auto&& add) {
    for (int q = 0; q < 2; ++q) {
      const double a = start[q], b = dir[q], c = start[1 - q], d = dir[1 - q];
      if (std::abs(b) <= 1e-15) continue;
      for (int j = -1; j <= 1; j += 2) {
        const double l = size[q] * j, t = (l - a) * (1 / b);
        if (t < 0 || t > 1) continue;
        const double other = c + d * t;
        if (std::abs(other) > size[1 - q]) continue;
        add(q, l, t, other);
      }
    }
  };
  // The face's frame in the world: its box's axes turned (axis a: sign_a × column axis_a).
  auto world_axes = [](const Rot3<double>& R, const FaceTurn& turn) {
    Rot3<double> F;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) F[b + 3 * a] = turn.sign[a] * R[b + 3 * turn.axis[a]];
    return F;
  };
  Rot3<double> F;
  V3 origin, normal;
  double hz;
  if (code < 12) {
    const int face = code % 6;
    const bool second = code >= 6;  // box 2's face, box 1 the other
    const FaceTurn turn = face_turn(face);
    const M3& rel = second ? rott : rot;
    const V3& so = second ? s1 : s2;  // the other box's half-sizes
    M3 r;  // r[a][b]: the face frame's axis a · the other box's axis b
    for (int a = 0; a < 3; ++a) r[a] = scaled(rel[turn.axis[a]], turn.sign[a]);
    auto other_axis = [&](int b) { return V3{r[0][b], r[1][b], r[2][b]}; };
    V3 p = turn(second ? pos12 : pos21);
    const V3 hs = turn(second ? s2 : s1);
    const V3 size{std::abs(hs[0]), std::abs(hs[1]), std::abs(hs[2])};
    hz = size[2];
    p[2] -= hz;  // from the face's centre
    int deep = 0;  // the other box's deepest corner: + along its axes that point down
    for (int i = 0; i < 3; ++i)
      if (r[2][i] < 0) deep += 1 << i;
    V3 lp = p;
    for (int i = 0; i < 3; ++i)
      lp = plus(lp, scaled(other_axis(i), so[i] * (deep & (1 << i) ? 1 : -1)));
    std::array<V3, 6> pts{};  // the corner, its edges within 30° of the face, their sums
    int m = 0;
    pts[m++] = lp;
    for (int i = 0; i < 3; ++i)
      if (std::abs(r[2][i]) < 0.5)
        pts[m++] = scaled(other_axis(i), so[i] * (deep & (1 << i) ? -2 : 2));
    pts[3] = plus(pts[0], pts[1]);
    pts[4] = plus(pts[0], pts[2]);
    pts[5] = plus(pts[3], pts[2]);
    auto add = [&](const V3& start, const V3& dir) {
      crossings(start, dir, size, [&](int, double, double t, double) {
        point[n++] = plus(start, scaled(dir, t));
      });
    };
    if (m > 1) add(pts[0], pts[1]);
    if (m > 2) add(pts[0], pts[2]), add(pts[3], pts[2]), add(pts[4], pts[1]);
    if (m > 2) {  // the rectangle's corners strictly inside the parallelogram
      const double a = pts[1][0], b = pts[2][0], c = pts[1][1], d = pts[2][1], det = a * d - b * c;
      for (int i = 0; i < 4; ++i) {
        const double llx = i / 2 ? size[0] : -size[0], lly = i % 2 ? size[1] : -size[1];
        const double x = llx - pts[0][0], y = lly - pts[0][1];
        const double u = (x * d - y * b) * (1 / det), v = (y * a - x * c) * (1 / det);
        if (u <= 0 || v <= 0 || u >= 1 || v >= 1) continue;
        point[n++] = {llx, lly, pts[0][2] + u * pts[1][2] + v * pts[2][2]};
      }
    }
    for (int i = 0; i < 1 << (m - 1); ++i) {  // its corners strictly over the rectangle
      const V3& c = pts[i == 0 ? 0 : i + 2];
      if (i && (c[0] <= -size[0] || c[0] >= size[0] || c[1] <= -size[1] || c[1] >= size[1]))
        continue;
      point[n++] = c;
    }
    int kept = 0;
    for (int i = 0; i < n; ++i) {
      if (point[i][2] > margin) continue;
      point[kept] = point[i];
      point[kept][2] *= 0.5;
      depth[kept] = point[kept][2];  // MuJoCo 2.2: dist the half depth
      ++kept;
    }
    n = kept;
    F = world_axes(second ? x2.rotation : x1.rotation, turn);
    origin = second ? x2.translation : x1.translation;
    normal = scaled(V3{F[6], F[7], F[8]}, second ? -1.0 : 1.0);
  } else {
    const int i1 = (code - 12) / 3, j2 = (code - 12) % 3;  // box 1's edge axis, box 2's
    int ax1 = j2 == 1 ? 0 : 1, ax2 = j2 == 2 ? 0 : 2;     // box 2's other axes
    int pax1 = i1 == 1 ? 0 : 1, pax2 = i1 == 2 ? 0 : 2;   // box 1's
    if (rotabs[i1][ax1] < rotabs[i1][ax2]) ax1 = ax2, ax2 = 3 - j2 - ax1;
    if (rotabs[pax1][j2] < rotabs[pax2][j2]) pax1 = pax2, pax2 = 3 - i1 - pax1;
    const FaceTurn turn = face_turn(cle1 & (1 << pax2) ? pax2 : pax2 + 3);
    M3 r;  // r[a][b]: box 1's face frame's axis a · box 2's axis b
    for (int a = 0; a < 3; ++a) r[a] = scaled(rot[turn.axis[a]], turn.sign[a]);
    auto axis2 = [&](int b) { return V3{r[0][b], r[1][b], r[2][b]}; };
    V3 p = turn(pos21);
    const V3 rnorm = turn(clnorm), hs = turn(s1);
    const V3 size{std::abs(hs[0]), std::abs(hs[1]), std::abs(hs[2])};
    hz = size[2];
    p[2] -= hz;
    auto side = [&](int k, bool flip) {  // box 2's half-size along its axis k, to cle2's side
      return scaled(axis2(k), s2[k] * (((cle2 & (1 << k)) != 0) != flip ? 1 : -1));
    };
    std::array<V3, 4> pu;  // box 2's edge's ends, then those of the one beside it
    pu[0] = plus(plus(p, side(ax1, false)), side(ax2, false));
    pu[1] = plus(pu[0], scaled(axis2(j2), -s2[j2]));
    pu[0] = plus(pu[0], scaled(axis2(j2), s2[j2]));
    pu[2] = plus(plus(p, side(ax1, true)), side(ax2, false));
    pu[3] = plus(pu[2], scaled(axis2(j2), -s2[j2]));
    pu[2] = plus(pu[2], scaled(axis2(j2), s2[j2]));
    if (std::abs(rnorm[2]) < 1e-15) return 0;
    const double innorm = (1 / rnorm[2]) * (in ? -1 : 1);
    std::array<V3, 4> pr;  // projected along the normal onto the face
    for (int i = 0; i < 4; ++i) pr[i] = plus(pu[i], scaled(rnorm, -pu[i][2] * (1 / rnorm[2])));
    const V3 axi1 = minus(pu[1], pu[0]), axi2 = minus(pu[2], pu[0]);
    const V3 pts1 = minus(pr[1], pr[0]), pts2 = minus(pr[2], pr[0]);
    // The projection's sides (start, direction) with box 2's own: two edges from corner 0, then
    // the two from the corners across.
    const std::array<std::array<V3, 4>, 4> lines{
        {{pr[0], pts1, pu[0], axi1},
         {pr[0], pts2, pu[0], axi2},
         {plus(pr[0], pts1), pts2, plus(pu[0], axi1), axi2},
         {plus(pr[0], pts2), pts1, plus(pu[0], axi2), axi1}}};
    for (const auto& [start, dir, ustart, udir] : lines) {
      crossings(start, dir, size, [&](int q, double l, double t, double other) {
        if ((ustart[2] + udir[2] * t) * innorm > margin) return;
        V3 x = plus(scaled(ustart, 0.5), scaled(udir, 0.5 * t));
        x[q] += 0.5 * l;
        x[1 - q] += 0.5 * other;
        depth[n] = x[2] * innorm * 2;
        point[n++] = x;
      });
    }
    const int nl = n;
    const double margin2 = margin * margin;
    const double a = pts1[0], b = pts2[0], c = pts1[1], d = pts2[1];
    double det = a * d - b * c;
    for (int i = 0; i < 4; ++i) {  // the face's corners in (or, with no crossing, beside) it
      const double llx = i / 2 ? size[0] : -size[0], lly = i % 2 ? size[1] : -size[1];
      const double x = llx - pr[0][0], y = lly - pr[0][1];
      double u = (x * d - y * b) * (1 / det), v = (y * a - x * c) * (1 / det);
      const bool u_out = u < 0 || u > 1, v_out = v < 0 || v > 1;
      if (nl == 0 ? u_out && v_out : u_out || v_out) continue;
      u = std::clamp(u, 0.0, 1.0), v = std::clamp(v, 0.0, 1.0);
      const V3 under = plus(plus(scaled(pu[0], 1 - u - v), scaled(pu[1], u)), scaled(pu[2], v));
      const V3 corner{llx, lly, 0}, gap = minus(corner, under);
      det = dot(gap, gap);  // MuJoCo 2.2 keeps the squared gap where the determinant was
      if (under[2] > 0 && det > margin2) continue;
      point[n] = scaled(plus(corner, under), 0.5);
      depth[n++] = std::sqrt(det) * (under[2] < 0 ? -1 : 1);
    }
    const int nf = n;
    for (int i = 0; i < 4; ++i) {  // box 2's corners over the face (or beside it)
      const double x = pr[i][0], y = pr[i][1];
      const bool x_out = x < -size[0] || x > size[0], y_out = y < -size[1] || y > size[1];
      if (nl == 0 ? nf != 0 && x_out && y_out : x_out || y_out) continue;
      double gap = 0;
      V3 mid{x * 0.5, y * 0.5, 0};
      for (int j = 0; j < 2; ++j) {
        if (pr[i][j] < -size[j]) {
          gap += (pr[i][j] + size[j]) * (pr[i][j] + size[j]);
          mid[j] = -size[j] * 0.5;
        } else if (pr[i][j] > size[j]) {
          gap += (pr[i][j] - size[j]) * (pr[i][j] - size[j]);
          mid[j] = size[j] * 0.5;
        }
      }
      gap += pu[i][2] * innorm * pu[i][2] * innorm;
      if (pu[i][2] > 0 && gap > margin2) continue;
      point[n] = plus(mid, scaled(pu[i], 0.5));
      depth[n++] = std::sqrt(gap) * (pu[i][2] < 0 ? -1 : 1);
    }
    F = world_axes(x1.rotation, turn);
    origin = x1.translation;
    normal = scaled(rotate(F, rnorm), in ? -1.0 : 1.0);
  }

  const std::array<double, 9> frame = contact_frame(normal, {0, 0, 0});
  for (int i = 0; i < n; ++i) {
    point[i][2] += hz;  // from the face's box's centre
    out[i] = {depth[i], plus(rotate(F, point[i]), origin), frame};
  }
  int count = 0;  // of points that are equal, mj_collideGeoms keeps the last
  for (int i = 0; i < n; ++i) {
    bool repeated = false;
    for (int k = i + 1; k < n; ++k) repeated |= out[k].pos == out[i].pos;
    if (!repeated) out[count++] = out[i];
  }
  return count;
}

}  // namespace detail

// The contacts of geoms a and b (a's shape not after b's), placed at xa and xb in the world,
// within margin: their count (at most max_pair_contacts), written to out in MuJoCo's order; −1
// for a pair of shapes collides() does not model, unless their bounding spheres are apart (0).
inline int collide(const Geom& a, const Transform<double>& xa, const Geom& b,
                   const Transform<double>& xb, double margin, Contact* out) {
  using namespace detail;
  const V3 pa = xa.translation, pb = xb.translation;
  // MuJoCo's bounding-sphere test first (mj_collideGeoms'): geoms whose spheres are further apart
  // than margin cannot touch, so no narrow phase (most of a scene's candidate pairs at any
  // state: the humanoid's 161 for a handful of contacts). Not against a plane (rbound 0).
  if (a.rbound > 0 && b.rbound > 0) {
    const V3 d = minus(pa, pb);
    if (std::sqrt(dot(d, d)) > a.rbound + b.rbound + margin) return 0;
  }
  const V3 za = z_axis(xa), zb = z_axis(xb);
  if (a.shape == Shape::plane) {
    if (b.shape == Shape::sphere) return plane_sphere(pa, za, pb, b.size[0], margin, {0, 0, 0}, out);
    if (b.shape == Shape::capsule) {  // its two end spheres, the tangent along its axis
      const V3 half = scaled(zb, b.size[1]);
      const int n = plane_sphere(pa, za, plus(pb, half), b.size[0], margin, zb, out);
      return n + plane_sphere(pa, za, minus(pb, half), b.size[0], margin, zb, out + n);
    }
    if (b.shape == Shape::ellipsoid) return plane_ellipsoid(pa, za, xb, b.size, margin, out);
    if (b.shape == Shape::cylinder) {
      const V3 x_axis{xb.rotation[0], xb.rotation[1], xb.rotation[2]};
      return plane_cylinder(pa, za, pb, zb, x_axis, b.size[0], b.size[1], margin, out);
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
    // (with a margin, the separating axes alone may let boxes further apart than that touch,
    // corner to corner: the bounding-sphere test above rules those out, as MuJoCo's)
    if (a.shape == Shape::box) return box_box(xa, a.size, xb, b.size, margin, out);
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
