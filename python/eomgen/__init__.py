"""eomgen from Python: a model's generated kernels as an extension module, built on demand.

    import eomgen
    panda = eomgen.build(urdf="models/robots/panda.urdf")          # compiled once, then cached
    qdd = panda.forward_dynamics(q, qd, u)                          # NumPy in, NumPy out

``build()`` writes a small CMake project that calls ``add_eom_model(... PYTHON_MODULE <name>)``
against this eomgen source tree (``add_subdirectory``), configures and compiles it, and imports
the module. The result is kept in a cache directory under a key made of the inputs' content and
the options (and the eomgen sources, the interpreter), so a second call with the same inputs
imports at once, in this process or the next. A model the generator refuses raises
:class:`BuildError` with the generator's message (file and line where it gives them).

The module's API (sizes, names, one function per kernel, ``integrate``, ``ensemble``) is
described in ``python/README.md`` and in each function's docstring.
"""

from ._build import BuildError, build, cache_dir, source_dir

__all__ = ["BuildError", "build", "cache_dir", "source_dir"]
