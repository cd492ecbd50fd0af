#!/usr/bin/env bash
# Opt-in check of `pip install <checkout>` (not in ctest: the first run compiles the generator,
# minutes; later runs reuse <checkout>/build-pip and take seconds):
#
#   tests/python/pip_install_check.sh [work folder, default: a temporary one]
#
# A virtual environment made with --system-site-packages (numpy, pybind11 from Debian), the
# package installed offline with Debian's setuptools (--no-index: nothing downloaded), then, in
# that environment, eomgen.build() of a small URDF from an empty cache against the generator that
# came with the package (none compiled in the cache), and a warm import in a new process.
set -euo pipefail
checkout="$(cd "$(dirname "$0")/../.." && pwd)"
work="${1:-$(mktemp -d)}"
"${PYTHON:-/usr/bin/python3}" -m venv --system-site-packages "$work/venv"  # Debian's: its setuptools
SECONDS=0
"$work/venv/bin/pip" install --no-index --quiet "$checkout"
echo "pip install: ${SECONDS} s"
cd "$work"
export EOMGEN_CACHE_DIR="$work/cache"
rm -rf "$EOMGEN_CACHE_DIR"
"$work/venv/bin/python" - "$checkout" <<'EOF'
import sys, time
from pathlib import Path
import eomgen
checkout = Path(sys.argv[1])
assert eomgen.config_dir() is not None and "site-packages" in str(eomgen.config_dir()), eomgen.config_dir()
start = time.perf_counter()
m = eomgen.build(urdf=checkout / "tests" / "urdf" / "robots" / "pendulum.urdf", quiet=True)
print(f"first eomgen.build() (pendulum, generator from the package): {time.perf_counter() - start:.1f} s")
assert not list(Path(eomgen.cache_dir()).glob("py-*/build/eomgen")), "the generator was compiled again"
assert m.nq == 1 and m.position_lower.shape == (1,)
EOF
"$work/venv/bin/python" - "$checkout" <<'EOF'
import sys, time
start = time.perf_counter()
import eomgen
m = eomgen.build(urdf=sys.argv[1] + "/tests/urdf/robots/pendulum.urdf", quiet=True)
print(f"warm eomgen.build() in a new process, import included: {time.perf_counter() - start:.3f} s")
EOF
echo "pip install check: ok ($work)"
