"""Shared fixtures of the Python tests: the C++ reference values (python_reference.cpp, run once
per session) and a table that calls each kernel from Python and puts its outputs back in the
kernel's own layout (column-major matrices, flattened), to compare bit for bit."""

import importlib
import json
import os
import subprocess
from types import SimpleNamespace

import numpy as np
import pytest

MODELS = ["chain10", "panda", "frame_arm", "cartesian_pendulum", "spacecraft_free", "py_pendulum"]


@pytest.fixture(scope="session")
def reference(tmp_path_factory):
    exe = os.environ.get("EOM_PYTHON_REFERENCE")
    if not exe:
        pytest.skip("EOM_PYTHON_REFERENCE (the python_reference program) is not set; run through ctest")
    path = tmp_path_factory.mktemp("reference") / "reference.json"
    subprocess.run([exe, str(path)], check=True)
    return json.loads(path.read_text())


def load(name):
    return importlib.import_module(name)


def inputs(ref_model):
    i = ref_model["inputs"]
    return SimpleNamespace(q=np.array(i["q"]), qd=np.array(i["qd"]), qdd=np.array(i["qdd"]),
                           u=np.array(i["u"]), p=np.array(i["p"]), t=float(i["t"]))


def kernel_layout(arrays, orders):
    """Python results back in the kernel's layout: 'F' for matrices (column-major), 'C' else."""
    return [np.asarray(a, dtype=float).ravel(order=o) for a, o in zip(arrays, orders)]


# kernel -> (call(module, inputs, frame, extra) -> (outputs tuple, status or None), layouts)
CALLS = {
    "mass_matrix": (lambda m, x, f, e: ((m.mass_matrix(x.q, x.p),), None), "F"),
    "mass_matrix_dot": (lambda m, x, f, e: ((m.mass_matrix_dot(x.q, x.qd, x.p),), None), "F"),
    "coriolis": (lambda m, x, f, e: ((m.coriolis(x.q, x.qd, x.p),), None), "C"),
    "potential_gradient": (lambda m, x, f, e: ((m.potential_gradient(x.q, x.p),), None), "C"),
    "generalized_forces": (lambda m, x, f, e: ((m.generalized_forces(x.q, x.qd, x.u, x.p, x.t),), None), "C"),
    "constraint_residual": (lambda m, x, f, e: ((m.constraint_residual(x.q, x.p),), None), "C"),
    "constraint_jacobian": (lambda m, x, f, e: ((m.constraint_jacobian(x.q, x.p),), None), "F"),
    "constraint_bias": (lambda m, x, f, e: ((m.constraint_bias(x.q, x.qd, x.p),), None), "C"),
    "forward_dynamics": (lambda m, x, f, e: _status(m.forward_dynamics(x.q, x.qd, x.u, x.p, x.t, status=True)), "C"),
    "kinetic_energy": (lambda m, x, f, e: ((m.kinetic_energy(x.q, x.qd, x.p),), None), "C"),
    "potential_energy": (lambda m, x, f, e: ((m.potential_energy(x.q, x.p),), None), "C"),
    "forward_dynamics_derivatives": (
        lambda m, x, f, e: _status(m.forward_dynamics_derivatives(x.q, x.qd, x.u, x.p, x.t, status=True)), "FFF"),
    "inverse_dynamics": (lambda m, x, f, e: ((m.inverse_dynamics(x.q, x.qd, x.qdd, x.u, x.p, x.t),), None), "C"),
    "inverse_dynamics_derivatives": (
        lambda m, x, f, e: (m.inverse_dynamics_derivatives(x.q, x.qd, x.qdd, x.u, x.p, x.t), None), "FF"),
    "taylor_coefficients": (
        lambda m, x, f, e: _status(m.taylor_coefficients(e["order"], x.q, x.qd, x.u, x.p, x.t, status=True)), "CC"),
    "forward_dynamics_parameter_derivatives": (
        lambda m, x, f, e: _status(m.forward_dynamics_parameter_derivatives(x.q, x.qd, x.u, x.p, x.t, status=True)),
        "F"),
    "frame_placement": (lambda m, x, f, e: (m.frame_placement(f, x.q, x.p), None), "CF"),
    "frame_jacobian": (lambda m, x, f, e: ((m.frame_jacobian(f, x.q, x.p),), None), "F"),
    "frame_acceleration_bias": (lambda m, x, f, e: ((m.frame_acceleration_bias(f, x.q, x.qd, x.p),), None), "C"),
    "center_of_mass": (lambda m, x, f, e: ((m.center_of_mass(x.q, x.p),), None), "C"),
    "center_of_mass_jacobian": (lambda m, x, f, e: ((m.center_of_mass_jacobian(x.q, x.p),), None), "F"),
    "centroidal_momentum_matrix": (lambda m, x, f, e: ((m.centroidal_momentum_matrix(x.q, x.p),), None), "F"),
}


def _status(result):
    *outputs, ok = result if isinstance(result, tuple) else (result,)
    if len(outputs) == 1 and isinstance(outputs[0], tuple):
        outputs = outputs[0]
    return tuple(outputs), ok


def call(module, kernel_entry, x, extra=None):
    """Calls the kernel named by a reference entry ("frame_jacobian/1" for frame 1)."""
    kernel, _, frame = kernel_entry.partition("/")
    fn, layout = CALLS[kernel]
    outputs, ok = fn(module, x, int(frame) if frame else None, extra or {})
    return outputs, ok, layout
