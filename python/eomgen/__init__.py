"""eomgen from Python: a model's generated kernels as an extension module, built on demand.

    import eomgen
    panda = eomgen.build(urdf="models/robots/panda.urdf")          # compiled once, then cached
    qdd = panda.forward_dynamics(q, qd, u)                          # NumPy in, NumPy out

``build()`` writes a small CMake project that calls ``add_eom_model(... PYTHON_MODULE <name>)``
against the installed eomgen (``find_package``: its generator is already built; `cmake
--install` or `pip install <checkout>` put this package there) or, for the package inside a
source tree, against that tree (``add_subdirectory``), configures and compiles it, and imports
the module. The result is kept in a cache directory under a key made of the inputs' content and
the options (and eomgen's files, the interpreter), so a second call with the same inputs
imports at once, in this process or the next. A model the generator refuses raises
:class:`BuildError` with the generator's message (your file and line where it gives them).

The options are add_eom_model()'s, one for one; the module's API (sizes, names, limits, one
function per kernel, ``integrate``, ``ensemble``) is described in ``python/README.md`` and in
each function's docstring.
"""

from ._build import OPTIONS, BuildError, build, cache_dir, config_dir, source_dir

__all__ = ["OPTIONS", "BuildError", "build", "cache_dir", "config_dir", "source_dir"]
