#!/usr/bin/env python3
"""The runtime's folders depend one way: a header includes only headers of its own folder or of
folders before it in the order that runtime/include/eom/README.md states on its `layers:` line.
Also: every header is in a folder, every folder is in that order and has a README.md.

  check_layers.py <runtime/include>    check the tree; exit 1 naming every violation
  check_layers.py --self-test          check that violations are found (a made-up tree)
"""
import re
import sys
import tempfile
from pathlib import Path

INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]eom/([^">]+)[">]', re.M)


def problems(root: Path) -> list[str]:
    eom = root / "eom"
    readme = eom / "README.md"
    match = re.search(r"^layers:(.*)$", readme.read_text(encoding="utf-8"), re.M)
    if not match:
        return [f"{readme}: no `layers:` line"]
    order = [name.strip() for name in match.group(1).split("→")]
    rank = {name: i for i, name in enumerate(order)}
    found = []
    for folder in sorted(p for p in eom.iterdir() if p.is_dir()):
        if folder.name not in rank:
            found.append(f"{folder}: a folder that the `layers:` line of {readme} does not name")
        elif not (folder / "README.md").is_file():
            found.append(f"{folder}: no README.md saying what lives there")
    for name in order:
        if not (eom / name).is_dir():
            found.append(f"{readme}: names `{name}`, which is not a folder of {eom}")
    for header in sorted(eom.rglob("*.hpp")):
        relative = header.relative_to(eom)
        if len(relative.parts) < 2:
            found.append(f"{header}: a header outside the folders")
            continue
        own = relative.parts[0]
        for line_no, line in enumerate(header.read_text(encoding="utf-8").splitlines(), 1):
            m = INCLUDE.match(line)
            if not m:
                continue
            target = m.group(1).split("/")[0]
            if target not in rank:
                found.append(f"{header}:{line_no}: includes eom/{m.group(1)}, outside the folders")
            elif own in rank and rank[target] > rank[own]:
                found.append(f"{header}:{line_no}: {own}/ includes eom/{m.group(1)}, but {target}/ "
                             f"comes after {own}/ ({' → '.join(order)})")
    return found


def self_test() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        eom = Path(tmp) / "eom"
        for name in ("low", "high", "stray"):
            (eom / name).mkdir(parents=True)
        (eom / "README.md").write_text("layers: low → high\n", encoding="utf-8")
        (eom / "low" / "README.md").write_text("low\n", encoding="utf-8")
        (eom / "low" / "a.hpp").write_text('#include "eom/high/b.hpp"\n', encoding="utf-8")
        (eom / "high" / "b.hpp").write_text("#include <eom/low/a.hpp>\n", encoding="utf-8")
        (eom / "top.hpp").write_text("", encoding="utf-8")
        found = "\n".join(problems(Path(tmp)))
        expected = ["a.hpp:1: low/ includes eom/high/b.hpp, but high/ comes after low/",
                    "high: no README.md", "stray: a folder that the `layers:` line",
                    "top.hpp: a header outside the folders"]
        missing = [e for e in expected if e not in found]
        extra = "b.hpp:1" in found  # a downward include is allowed
        if missing or extra:
            print("self-test failed; missing:", missing, "wrongly reported b.hpp:", extra)
            print(found)
            return 1
    print("self-test: every planted violation found, the allowed include not reported")
    return 0


def main() -> int:
    if sys.argv[1:] == ["--self-test"]:
        return self_test()
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    found = problems(Path(sys.argv[1]))
    for p in found:
        print(p)
    if not found:
        print("the runtime's folders depend one way")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
