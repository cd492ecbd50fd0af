#!/usr/bin/python3
"""The symbolic peer: eomgen's models derived the way a SymPy user would, and printed as C++.

    sympy_models.py MODEL --out-dir DIR [--stats FILE]

MODEL is chain<N> (eom::models::Chain<N>, e.g. chain10), spring_pendulum, double_pendulum,
cartesian_pendulum or closed_chain5. Writes DIR/sympy_<MODEL>.hpp and .cpp with, in namespace
sympy_<MODEL> (matrices column-major, p laid out as in the model's `parameters`):

    void mass_matrix(const double* q, const double* p, double* M);
    void coriolis(const double* q, const double* qd, const double* p, double* c);
    void dynamics_terms(double t, const double* q, const double* qd, const double* p,
                        double* M, double* f [, double* C, double* gamma]);  // C, γ when nc > 0

with M q̈ + Cᵀμ = f and C q̈ = −γ (docs/CONTRACT.md §2); the caller solves that numerically (a symbolic
LUsolve is the slow and fragile option).

The route: sympy.physics.mechanics' LagrangesMethod on the Lagrangian (for the chains one
ReferenceFrame and one RigidBody per link, their Lagrangian(), the hinge dampers and the drive as
torques on the link frames); cse() over each function's outputs; the C99 printer (ccode) for
every assignment. Nothing is hand-simplified. The mechanics, coordinates and parameter layout are
those of models/*.hpp. LagrangesMethod's forcing is Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇, so the
velocity-product vector is c = −forcing with the potential and the loads switched off (their
parameters set to 0); C = ∂φ/∂q and γ = Ċ q̇ are differentiated directly.

--stats FILE writes one JSON object: seconds per stage (derive, cse, print), emitted bytes and
operation counts (sympy.count_ops after cse) per function.
"""

import argparse
import json
import os
import re
import sys
import time

try:
    import sympy as sp
    from sympy.physics.mechanics import (LagrangesMethod, Lagrangian, Point, ReferenceFrame,
                                         RigidBody, dynamicsymbols, inertia)
except ImportError:
    sys.exit("sympy_models.py: SymPy is missing; install it with: apt-get install python3-sympy")


def progress(message):
    print(f"sympy_models: {message}", file=sys.stderr, flush=True)


T = dynamicsymbols._t


class Derived:
    """What every model gives: coordinates, parameters (model order), the method and the rest."""

    def __init__(self, q, params, method, loads_off, constraints=()):
        self.q, self.params, self.method = q, params, method
        self.loads_off = loads_off  # parameters that switch off V and Q when set to 0
        self.constraints = list(constraints)


def lagrange(lagrangian, q, loads=None, frame=None):
    method = LagrangesMethod(lagrangian, q, forcelist=loads, frame=frame)
    method.form_lagranges_equations()
    return method


def chain(n, closed=False):
    """Chain<n> of models/chain.hpp; closed=True gives ClosedChain5's loop, drive and damper 6."""
    theta = dynamicsymbols(f"theta1:{n + 1}")
    rate = [sp.diff(x, T) for x in theta]
    m, l, inertia_zz, c = (sp.symbols(f"{k}1:{n + 1}") for k in ("m", "l", "I", "c"))
    g = sp.Symbol("g")
    params = [*m, *l, *inertia_zz, *c, g]

    ground = ReferenceFrame("N")
    pin = Point("O")
    pin.set_vel(ground, 0)
    joint, bodies, links = pin, [], []
    for i in range(n):
        link = ground.orientnew(f"A{i + 1}", "Axis", [theta[i], ground.z])
        centre = joint.locatenew(f"G{i + 1}", l[i] / 2 * link.x)
        centre.v2pt_theory(joint, ground, link)
        body = RigidBody(f"B{i + 1}", centre, link, m[i],
                         (inertia(link, 0, 0, inertia_zz[i]), centre))
        body.potential_energy = m[i] * g * centre.pos_from(pin).dot(ground.y)
        bodies.append(body)
        links.append(link)
        following = joint.locatenew(f"P{i + 2}", l[i] * link.x)
        following.v2pt_theory(joint, ground, link)
        joint = following
    # Hinge i: its damper's torque on link i and the reaction on link i-1 (the ground for i = 1).
    torque = [sp.S.Zero] * n
    for i in range(n):
        relative_rate = rate[i] - (rate[i - 1] if i > 0 else 0)
        torque[i] += -c[i] * relative_rate
        if i > 0:
            torque[i - 1] += c[i] * relative_rate
    loads_off = [g, *c]
    constraints = []
    if closed:
        dx, dy, c_close, tau, omega = sp.symbols("dx dy c6 tau Omega")
        params += [dx, dy, c_close, tau, omega]
        torque[n - 1] += -c_close * rate[n - 1]      # closing hinge: link n against the ground
        torque[0] += tau * sp.sin(omega * T)          # the drive on link 1
        loads_off += [c_close, tau]
        end = joint.pos_from(pin)
        constraints = [end.dot(ground.x) - dx, end.dot(ground.y) - dy]
    loads = [(links[i], torque[i] * ground.z) for i in range(n)]
    method = lagrange(Lagrangian(ground, *bodies), theta, loads, ground)
    return Derived(theta, params, method, loads_off, constraints)


def spring_pendulum():
    r, theta = dynamicsymbols("r theta")
    rd, thetad = sp.diff(r, T), sp.diff(theta, T)
    m, k, r0, g = sp.symbols("m k r0 g")
    kinetic = m / 2 * (rd**2 + r**2 * thetad**2)
    potential = k / 2 * (r - r0)**2 + m * g * (r0 - r * sp.cos(theta))
    return Derived([r, theta], [m, k, r0, g], lagrange(kinetic - potential, [r, theta]), [k, g])


def double_pendulum():
    a1, a2 = dynamicsymbols("a1 a2")
    a1d, a2d = sp.diff(a1, T), sp.diff(a2, T)
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g")
    kinetic = ((m1 + m2) * l1**2 * a1d**2 / 2 + m2 * l2**2 * a2d**2 / 2
               + m2 * l1 * l2 * a1d * a2d * sp.cos(a1 - a2))
    potential = -(m1 + m2) * g * l1 * sp.cos(a1) - m2 * g * l2 * sp.cos(a2)
    return Derived([a1, a2], [m1, m2, l1, l2, g], lagrange(kinetic - potential, [a1, a2]), [g])


def cartesian_pendulum():
    x, y = dynamicsymbols("x y")
    m, l, g = sp.symbols("m l g")
    kinetic = m / 2 * (sp.diff(x, T)**2 + sp.diff(y, T)**2)
    return Derived([x, y], [m, l, g], lagrange(kinetic - m * g * y, [x, y]), [g],
                   [x**2 + y**2 - l**2])


def derive(model):
    match = re.fullmatch(r"chain([1-9][0-9]*)", model)
    if match:
        return chain(int(match.group(1)))
    known = {"spring_pendulum": spring_pendulum, "double_pendulum": double_pendulum,
             "cartesian_pendulum": cartesian_pendulum, "closed_chain5": lambda: chain(5, True)}
    if model not in known:
        sys.exit(f"sympy_models.py: unknown model '{model}'; expected chain<N> or one of "
                 + ", ".join(known))
    return known[model]()


def to_c(name, signature, outputs, stats):
    """One C++ function: cse over the outputs [(target, expr)], then one ccode line each."""
    start = time.perf_counter()
    temporaries, reduced = sp.cse([e for _, e in outputs])
    stats["cse_s"] += time.perf_counter() - start
    start = time.perf_counter()
    ops = sum(sp.count_ops(e) for _, e in temporaries) + sum(sp.count_ops(e) for e in reduced)
    lines = [f"// {name} ({ops} operations after cse, by sympy.count_ops)",
             f"void {name}({signature}) {{"]
    for symbol, expr in temporaries:
        lines.append(f"  const double {symbol} = {sp.ccode(expr, standard='C99')};")
    for (target, _), expr in zip(outputs, reduced):
        lines.append(f"  {target} = {sp.ccode(expr, standard='C99')};")
    lines.append("}")
    text = "\n".join(lines) + "\n"
    stats["print_s"] += time.perf_counter() - start
    stats["functions"][name] = {"ops": int(ops), "bytes": len(text.encode())}
    return text


def write_if_changed(path, text):
    """Rewrites only on change (builds stay incremental), by rename (never half-written)."""
    if os.path.exists(path):
        with open(path, encoding="utf-8") as fh:
            if fh.read() == text:
                return
    with open(path + ".tmp", "w", encoding="utf-8") as fh:
        fh.write(text)
    os.replace(path + ".tmp", path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model", help="chain<N>, spring_pendulum, double_pendulum, "
                                      "cartesian_pendulum or closed_chain5")
    parser.add_argument("--out-dir", required=True)
    parser.add_argument("--stats", help="write timings, sizes and operation counts here (JSON)")
    args = parser.parse_args()

    stats = {"model": args.model, "sympy": sp.__version__, "derive_s": 0.0, "cse_s": 0.0,
             "print_s": 0.0, "functions": {}}
    progress(f"{args.model}: LagrangesMethod")
    start = time.perf_counter()
    d = derive(args.model)
    n, nc = len(d.q), len(d.constraints)
    # The C names: q[i], qd[i], p[k], t.
    names = {sp.diff(x, T): sp.Symbol(f"qd[{i}]") for i, x in enumerate(d.q)}
    names.update({x: sp.Symbol(f"q[{i}]") for i, x in enumerate(d.q)})
    names.update({s: sp.Symbol(f"p[{k}]") for k, s in enumerate(d.params)})
    names[T] = sp.Symbol("t")
    mass = d.method.mass_matrix.xreplace(names)
    forcing = d.method.forcing.xreplace(names)
    coriolis = (-d.method.forcing.subs({s: 0 for s in d.loads_off})).xreplace(names)
    if nc:
        phi = sp.Matrix(d.constraints)
        jacobian = phi.jacobian(d.q)
        bias = jacobian.diff(T) * sp.Matrix([sp.diff(x, T) for x in d.q])  # γ = Ċ q̇
        jacobian, bias = jacobian.xreplace(names), bias.xreplace(names)
    stats["derive_s"] = time.perf_counter() - start
    progress(f"{args.model}: derived in {stats['derive_s']:.1f} s; cse and printing")

    def column_major(target, matrix):
        rows, cols = matrix.shape
        return [(f"{target}[{i + rows * j}]", matrix[i, j]) for j in range(cols)
                for i in range(rows)]

    extra_signature = ", double* C, double* gamma" if nc else ""
    terms = column_major("M", mass) + [(f"f[{i}]", forcing[i]) for i in range(n)]
    if nc:
        terms += column_major("C", jacobian) + [(f"gamma[{i}]", bias[i]) for i in range(nc)]
    body = [
        to_c("mass_matrix", "const double* q, const double* p, double* M",
             column_major("M", mass), stats),
        to_c("coriolis", "const double* q, const double* qd, const double* p, double* c",
             [(f"c[{i}]", coriolis[i]) for i in range(n)], stats),
        to_c("dynamics_terms", "double t, const double* q, const double* qd, const double* p, "
             "double* M, double* f" + extra_signature, terms, stats),
    ]
    ns = f"sympy_{args.model}"
    header = f"""// {ns}: {args.model} by SymPy {sp.__version__} (LagrangesMethod, cse, ccode),
// written by bench/sympy_models.py. Column-major; M q̈ + Cᵀμ = f, C q̈ = −γ.
#pragma once
namespace {ns} {{
void mass_matrix(const double* q, const double* p, double* M);
void coriolis(const double* q, const double* qd, const double* p, double* c);
void dynamics_terms(double t, const double* q, const double* qd, const double* p, double* M,
                    double* f{extra_signature});
// The functions as one type, for templates.
struct Functions {{
  static constexpr int nq = {n}, np = {len(d.params)}, nc = {nc};
  static constexpr auto mass_matrix = &{ns}::mass_matrix;
  static constexpr auto coriolis = &{ns}::coriolis;
  static constexpr auto dynamics_terms = &{ns}::dynamics_terms;
}};
}}  // namespace {ns}
"""
    source = (f"// {ns}: written by bench/sympy_models.py from SymPy's output. Do not edit.\n"
              f'#include "{ns}.hpp"\n\n#include <cmath>\n\nnamespace {ns} {{\n'
              "using std::cos, std::sin, std::pow, std::sqrt;\n\n"
              + "\n".join(body) + f"\n}}  // namespace {ns}\n")
    os.makedirs(args.out_dir, exist_ok=True)
    write_if_changed(os.path.join(args.out_dir, ns + ".hpp"), header)
    write_if_changed(os.path.join(args.out_dir, ns + ".cpp"), source)
    stats["bytes"] = len(source.encode())
    total = stats["derive_s"] + stats["cse_s"] + stats["print_s"]
    progress(f"{args.model}: done in {total:.1f} s (cse {stats['cse_s']:.1f} s, print "
             f"{stats['print_s']:.1f} s), {stats['bytes']} bytes")
    if args.stats:
        with open(args.stats, "w", encoding="utf-8") as fh:
            json.dump(stats, fh, indent=1)


if __name__ == "__main__":
    main()
