"""The package's layering, as the README's module map states it.

The README lists every module in the order data flows through the package; at import time a
module may import only modules listed before it (the ``Mechanism`` methods and a few functions
import later stages inside the function, which this test does not see). A new module must be
added to the map, and an import against the flow fails here.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import loopsolve

PACKAGE = Path(loopsolve.__file__).parent
README = PACKAGE.parent / "README.md"


def _module_map() -> list[str]:
    text = README.read_text(encoding="utf-8")
    table = text[text.index("| stage | modules |"):]
    table = table[: table.index("\n\n")]
    order = []
    for row in table.splitlines()[2:]:
        cells = row.split("|")
        names = re.findall(r"`([a-z_]+)`", re.sub(r"\([^)]*\)", "", cells[2]))  # not the remarks
        order += [m for m in names if (PACKAGE / f"{m}.py").exists()]
    return order


def test_the_module_map_lists_every_module_once():
    order = _module_map()
    modules = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__")
    assert sorted(order) == modules


def test_no_module_imports_a_later_stage_at_import_time():
    order = _module_map()
    pos = {m: i for i, m in enumerate(order)}
    wrong = []
    for m in order:
        for node in ast.parse((PACKAGE / f"{m}.py").read_text(encoding="utf-8")).body:
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                deps = [node.module] if node.module else [a.name for a in node.names]
                wrong += [f"{m} imports {d}" for d in (x.split(".")[0] for x in deps) if pos.get(d, -1) > pos[m]]
    assert wrong == []
