#!/usr/bin/env python3
"""Consistency check for the bundled URDF files (models/robots/*.urdf).

Standard library only.  For every file given (default: models/robots/*.urdf):
  * well-formed XML, plain ASCII, numbers in decimal notation (no exponents);
  * no <visual>, <gazebo>, <transmission> or <mesh>; a <collision> only as a
    <sphere radius> (solo12_feet.urdf's feet), in decimal notation;
  * kinematic tree: unique link names, every joint's parent/child exists, every
    link has at most one parent joint, exactly one root, no cycle, all links reached;
  * joints: known type, non-zero axis for moving joints, <limit effort velocity>
    for revolute/prismatic, damping/friction >= 0;
  * inertials: mass >= 0, inertia tensor (about the COM, inertial frame) with
    eigenvalues >= 0 and principal moments satisfying the triangle inequality;
  * prints a summary and the q = 0 positions of the leaf links in the root frame.
Exit status 0 if every check passes, 1 otherwise.
"""
import glob
import math
import os
import re
import sys
import xml.etree.ElementTree as ET

TOL = 1e-12  # kg m^2, slack for rounding in the published tensors
FORBIDDEN = ("visual", "gazebo", "transmission", "mesh")
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
NUM_ATTRS = {"origin": ("xyz", "rpy"), "axis": ("xyz",), "mass": ("value",),
             "inertia": ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"),
             "limit": ("lower", "upper", "effort", "velocity"),
             "dynamics": ("damping", "friction"), "sphere": ("radius",)}


def vec(s, n=3):
    v = [float(t) for t in s.split()]
    if len(v) != n:
        raise ValueError("expected %d numbers, got %r" % (n, s))
    return v


def rpy_matrix(r, p, y):
    """URDF fixed-axis roll-pitch-yaw: R = Rz(y) Ry(p) Rx(r)."""
    cr, sr, cp, sp, cy, sy = (math.cos(r), math.sin(r), math.cos(p),
                              math.sin(p), math.cos(y), math.sin(y))
    return [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr]]


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def matvec(a, v):
    return [sum(a[i][k] * v[k] for k in range(3)) for i in range(3)]


def sym_eigenvalues(m):
    """Eigenvalues of a symmetric 3x3 matrix by cyclic Jacobi rotations."""
    a = [row[:] for row in m]
    for _ in range(100):
        off = sum(a[i][j] ** 2 for i in range(3) for j in range(3) if i != j)
        if off < 1e-40:
            break
        for p in range(3):
            for q in range(p + 1, 3):
                if abs(a[p][q]) < 1e-300:
                    continue
                theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q])
                t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(3):  # A <- A J
                    akp, akq = a[k][p], a[k][q]
                    a[k][p], a[k][q] = c * akp - s * akq, s * akp + c * akq
                for k in range(3):  # A <- J^T A
                    apk, aqk = a[p][k], a[q][k]
                    a[p][k], a[q][k] = c * apk - s * aqk, s * apk + c * aqk
    return sorted(a[i][i] for i in range(3))


def check_file(path):
    errors, notes = [], []
    raw = open(path, "rb").read()
    try:
        raw.decode("ascii")
    except UnicodeDecodeError as e:
        errors.append("not plain ASCII (byte %d)" % e.start)
    try:
        root = ET.fromstring(raw)
    except ET.ParseError as e:
        return ["XML parse error: %s" % e], notes
    if root.tag != "robot":
        errors.append("root element is <%s>, not <robot>" % root.tag)

    for el in root.iter():
        if el.tag in FORBIDDEN:
            errors.append("forbidden element <%s>" % el.tag)
        if el.tag == "collision":
            shapes = [g.tag for g in el.findall("geometry/*")]
            if shapes != ["sphere"] or float(el.find("geometry/sphere").get("radius", "0")) <= 0:
                errors.append("<collision %s>: not one sphere of positive radius" % el.get("name", ""))
        for attr in NUM_ATTRS.get(el.tag, ()):
            s = el.get(attr)
            if s is not None and re.search(r"[eE]", s):
                errors.append("<%s %s=%r>: not in decimal notation" % (el.tag, attr, s))

    links = {}
    for l in root.findall("link"):
        name = l.get("name")
        if name in links:
            errors.append("duplicate link %r" % name)
        links[name] = l
    joints = {}
    parent_of = {}
    children = {n: [] for n in links}
    for j in root.findall("joint"):
        name, jtype = j.get("name"), j.get("type")
        if name in joints:
            errors.append("duplicate joint %r" % name)
        joints[name] = j
        if jtype not in JOINT_TYPES:
            errors.append("joint %r: unknown type %r" % (name, jtype))
        pe, ce = j.find("parent"), j.find("child")
        if pe is None or ce is None:
            errors.append("joint %r: missing parent or child" % name)
            continue
        p, c = pe.get("link"), ce.get("link")
        for side, ln in (("parent", p), ("child", c)):
            if ln not in links:
                errors.append("joint %r: %s link %r does not exist" % (name, side, ln))
        if c in parent_of:
            errors.append("link %r has two parent joints (%r, %r)" % (c, parent_of[c], name))
        parent_of[c] = name
        if p in children:
            children[p].append((name, c))
        if jtype in ("revolute", "continuous", "prismatic", "planar"):
            ae = j.find("axis")
            axis = vec(ae.get("xyz")) if ae is not None else [1.0, 0.0, 0.0]
            n = math.sqrt(sum(a * a for a in axis))
            if n == 0.0:
                errors.append("joint %r: zero axis" % name)
            elif abs(n - 1.0) > 1e-9:
                notes.append("joint %r: axis %s has norm %.6g (URDF normalises it)" % (name, axis, n))
        if jtype in ("revolute", "prismatic"):
            le = j.find("limit")
            if le is None or le.get("effort") is None or le.get("velocity") is None:
                errors.append("joint %r: %s joint needs <limit effort velocity>" % (name, jtype))
            elif le.get("lower") is not None and le.get("upper") is not None \
                    and float(le.get("lower")) > float(le.get("upper")):
                errors.append("joint %r: lower > upper" % name)
        de = j.find("dynamics")
        if de is not None:
            for a in ("damping", "friction"):
                if de.get(a) is not None and float(de.get(a)) < 0:
                    errors.append("joint %r: negative %s" % (name, a))

    roots = [n for n in links if n not in parent_of]
    if len(roots) != 1:
        errors.append("expected exactly one root link, found %s" % roots)
        return errors, notes
    rootname = roots[0]

    # walk the tree, q = 0 poses
    pose = {rootname: ([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]], [0.0, 0.0, 0.0])}
    stack, seen = [rootname], {rootname}
    while stack:
        ln = stack.pop()
        R, p = pose[ln]
        for jn, c in children.get(ln, []):
            if c in seen:
                errors.append("cycle through link %r" % c)
                continue
            seen.add(c)
            oe = joints[jn].find("origin")
            xyz = vec(oe.get("xyz", "0 0 0")) if oe is not None else [0.0] * 3
            rpy = vec(oe.get("rpy", "0 0 0")) if oe is not None else [0.0] * 3
            pc = [p[i] + matvec(R, xyz)[i] for i in range(3)]
            pose[c] = (matmul(R, rpy_matrix(*rpy)), pc)
            stack.append(c)
    if seen != set(links):
        errors.append("links not reached from the root: %s" % sorted(set(links) - seen))

    total_mass, massless = 0.0, []
    for name, l in links.items():
        ie = l.find("inertial")
        if ie is None:
            massless.append(name)
            continue
        me, ite = ie.find("mass"), ie.find("inertia")
        if me is None or ite is None:
            errors.append("link %r: <inertial> without <mass> or <inertia>" % name)
            continue
        m = float(me.get("value"))
        if m < 0:
            errors.append("link %r: negative mass %g" % (name, m))
        total_mass += m
        g = {k: float(ite.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        I = [[g["ixx"], g["ixy"], g["ixz"]],
             [g["ixy"], g["iyy"], g["iyz"]],
             [g["ixz"], g["iyz"], g["izz"]]]
        ev = sym_eigenvalues(I)
        if ev[0] < -TOL:
            errors.append("link %r: inertia not positive semidefinite, eigenvalues %s" % (name, ev))
        if ev[0] + ev[1] < ev[2] - TOL:
            errors.append("link %r: triangle inequality violated, principal moments %s" % (name, ev))
        if m > 0 and ev[2] <= 0:
            notes.append("link %r: mass %g with zero inertia (point mass)" % (name, m))
        if m == 0 and ev[2] > 0:
            errors.append("link %r: zero mass with non-zero inertia" % name)
        notes.append("link %-18s m = %-10g principal moments = %.6g %.6g %.6g  (l1+l2-l3 = %.3g)"
                     % (name, m, ev[0], ev[1], ev[2], ev[0] + ev[1] - ev[2]))

    types = {}
    for j in joints.values():
        types[j.get("type")] = types.get(j.get("type"), 0) + 1
    dof = sum(v for k, v in types.items() if k in ("revolute", "continuous", "prismatic"))
    damped = [n for n, j in joints.items() if j.find("dynamics") is not None
              and float(j.find("dynamics").get("damping", "0")) > 0]
    notes.insert(0, "root %r, %d links, joints %s, %d DOF, total mass %.6g kg, massless links %s, "
                    "joints with damping > 0: %d" % (rootname, len(links), types, dof, total_mass,
                                                      massless, len(damped)))
    for ln in sorted(links):
        if not children.get(ln) and ln in pose:
            p = pose[ln][1]
            notes.append("q = 0: leaf %-16s at (%.6f, %.6f, %.6f) m in %r" % (ln, p[0], p[1], p[2], rootname))
    return errors, notes


def main(argv):
    here = os.path.dirname(os.path.abspath(__file__))
    files = argv[1:] or sorted(glob.glob(os.path.join(here, "..", "models", "robots", "*.urdf")))
    if not files:
        print("no URDF files found")
        return 1
    failed = 0
    for f in files:
        errors, notes = check_file(f)
        print("== %s: %s" % (os.path.relpath(f), "OK" if not errors else "FAILED"))
        for n in notes:
            print("   " + n)
        for e in errors:
            print("   ERROR: " + e)
        failed += bool(errors)
    print("%d file(s), %d failed" % (len(files), failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
