"""One-way imports between loopsolve's subpackages (issue 24; ARCHITECTURE.md).

The layers, lowest first: ``errors`` (every layer raises its errors), ``model``, ``symbolic``,
``kinematics``, ``dynamics``, ``design``, ``output``, and at the top ``cli`` together with the
package's ``__init__`` (the public API, which the command line may use). Every import in ``loopsolve/`` is read with ``ast`` — at module level and
inside functions (lazy imports) alike — and an import of a higher layer fails here, unless it is
one of the convenience methods listed in :data:`loopsolve._layering.FACADE` (``mech.sweep``,
``sweep.plot``, ...): the single documented way up.
"""

from __future__ import annotations

import ast
from pathlib import Path

import loopsolve
from loopsolve._layering import CYCLES, FACADE, LAYERS, WITHIN_LAYER

PACKAGE = Path(loopsolve.__file__).parent


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _layer(module: str) -> int:
    """Rank of a dotted module name (``loopsolve.kinematics.sweep`` -> rank of ``kinematics``)."""
    parts = module.split(".")
    if len(parts) == 1:
        return LAYERS.index("cli")  # loopsolve/__init__.py: the public API, the top layer with the CLI
    name = parts[1]
    if name in ("_layering", "_moved"):
        return 0
    if name not in LAYERS:  # loopsolve.__main__, or a name of the public API (`from .. import guessed_mode`)
        return LAYERS.index("cli")
    return LAYERS.index(name)


def _imports(path: Path):
    """(importing function's qualified name or "", imported module) for every import in a file."""
    module = _module_name(path)
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []

    def visit(node, scope):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                continue  # annotations only: never imported when the code runs
            inner = scope
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                inner = f"{scope}.{child.name}" if scope else child.name
            if isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package.split(".")[: len(package.split(".")) - child.level + 1]
                    target = ".".join(base + ([child.module] if child.module else []))
                else:
                    target = child.module or ""
                if target.startswith("loopsolve"):
                    if child.module is None or target.count(".") == 1 and target.split(".")[1] in LAYERS:
                        # `from . import x` / `from ..model import spec`: the names are modules
                        out.extend((scope, f"{target}.{a.name}") for a in child.names)
                    else:
                        out.append((scope, target))
            elif isinstance(child, ast.Import):
                out.extend((scope, a.name) for a in child.names if a.name.startswith("loopsolve"))
            visit(child, inner)

    visit(tree, "")
    return module, out


def _upward_imports():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        module, imports = _imports(path)
        for scope, target in imports:
            if target.split(".")[:2] == ["loopsolve", "__version__"] or target == "loopsolve":
                continue
            if _layer(target) > _layer(module):
                found.append((module.removeprefix("loopsolve."), scope, target.removeprefix("loopsolve.")))
    return found


def test_every_module_belongs_to_a_layer():
    stray = []
    for path in PACKAGE.rglob("*.py"):
        module = _module_name(path)
        parts = module.split(".")
        if len(parts) > 1 and parts[1] not in LAYERS and parts[1] not in ("__main__", "_layering", "_moved"):
            stray.append(module)
    assert stray == [], f"modules outside the layers (put them in a subpackage): {stray}"


def test_no_layer_imports_a_higher_one_except_the_facade():
    allowed = {(m, f) for m, f, _ in FACADE}
    wrong = [f"{m} ({f or 'module level'}) imports {t}" for m, f, t in _upward_imports() if (m, f) not in allowed]
    assert wrong == []


def test_the_facade_list_names_only_real_upward_imports():
    """A stale entry (the method moved or no longer reaches up) is removed from the list."""
    used = {(m, f) for m, f, _ in _upward_imports()}
    stale = [(m, f) for m, f, _ in FACADE if (m, f) not in used]
    assert stale == []


def test_the_facade_targets_are_what_the_list_says():
    listed = {(m, f, t) for m, f, t in FACADE}
    reached = {(m, f, t.split(".")[0] + "." + t.split(".")[1]) for m, f, t in _upward_imports()
               if any((m, f) == (lm, lf) for lm, lf, _ in FACADE)}
    assert reached <= listed


def _back_references():
    """Lazy imports inside one layer that point back at a module importing the importer at module level."""
    eager, lazy = {}, {}
    for path in sorted(PACKAGE.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        module, imports = _imports(path)
        for scope, target in imports:
            if target.count(".") >= 2 and module.count(".") >= 1 and target.split(".")[1] == module.split(".")[1]:
                (lazy if scope else eager).setdefault(module, set()).add(target)

    def imported_by(start):  # every module that `start` imports at module level, transitively
        seen, todo = set(), [start]
        while todo:
            for nxt in eager.get(todo.pop(), ()):
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        return seen

    return {(m.removeprefix("loopsolve."), t.removeprefix("loopsolve."))
            for m, targets in lazy.items() for t in targets if m in imported_by(t)}


def test_back_references_inside_a_layer_are_the_listed_ones():
    """No hidden import cycle inside a layer: each lazy import back is listed, with its reason."""
    assert _back_references() == {(m, t) for m, t, _ in WITHIN_LAYER}


def _cycles():
    """Every import cycle inside a layer, lazy imports (inside functions) included: the strongly connected
    components of the graph module → module it imports, anywhere in its code."""
    import networkx as nx

    modules = {_module_name(p) for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts}
    graph = nx.DiGraph()
    for path in sorted(PACKAGE.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        module, imports = _imports(path)
        for _, target in imports:
            if target in modules and target != module and target.count(".") >= 1 and module.count(".") >= 1 \
                    and target.split(".")[1] == module.split(".")[1]:
                graph.add_edge(module.removeprefix("loopsolve."), target.removeprefix("loopsolve."))
    return {frozenset(c) for c in nx.strongly_connected_components(graph) if len(c) > 1}


def test_import_cycles_inside_a_layer_are_the_listed_ones():
    """A cycle, even through imports inside functions, is two modules that cannot be understood (or moved)
    apart: each is listed in loopsolve._layering.CYCLES with its reason, and a broken one leaves the list."""
    listed = {frozenset(c) for c, _ in CYCLES}
    found = _cycles()
    assert sorted(map(sorted, found - listed)) == [], "unlisted import cycles: break them or list them with a reason"
    assert sorted(map(sorted, listed - found)) == [], "listed cycles that no longer exist: remove them from CYCLES"


def test_the_cycle_check_sees_a_cycle_made_only_of_lazy_imports(tmp_path, monkeypatch):
    """The check itself: two modules of one layer importing each other only inside functions form a cycle."""
    pkg = tmp_path / "loopsolve"
    (pkg / "design").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "design" / "__init__.py").write_text("")
    (pkg / "design" / "a.py").write_text("def f():\n    from .b import g\n    return g()\n")
    (pkg / "design" / "b.py").write_text("def g():\n    from .a import f\n    return f\n")
    (pkg / "design" / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .a import f\n")
    monkeypatch.setitem(globals(), "PACKAGE", pkg)
    assert _cycles() == {frozenset({"design.a", "design.b"})}


def _private_name_imports():
    """``module imports _name from target`` for every underscored name one loopsolve module imports from
    another (``from .spec import _check``); private modules (``from . import _moved``) and dunders are fine."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        module = _module_name(path)
        package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.ImportFrom):
                continue
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith("loopsolve"):
                continue
            where = PACKAGE.parent.joinpath(*target.split("."))
            for alias in node.names:
                name = alias.name
                if not name.startswith("_") or name.startswith("__"):
                    continue
                if (where / f"{name}.py").is_file() or (where / name / "__init__.py").is_file():
                    continue  # a private module of the package: its own business
                found.append(f"{module} imports {name} from {target}")
    return found


def test_no_module_imports_another_modules_private_name():
    """A name with a leading underscore belongs to its module: a helper two modules share gets a public
    name in the module that owns it (or lives in a private module of its layer, e.g. ``cli/_shared.py``)."""
    assert _private_name_imports() == []


def test_the_private_import_check_sees_a_private_name_and_allows_a_private_module(tmp_path, monkeypatch):
    """The check itself: ``from .a import _helper`` is reported, ``from . import _private`` and
    ``from .a import __version__`` are not."""
    pkg = tmp_path / "loopsolve"
    (pkg / "model").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from . import _private\nfrom .model.a import __version__\n")
    (pkg / "_private.py").write_text("")
    (pkg / "model" / "__init__.py").write_text("")
    (pkg / "model" / "a.py").write_text("__version__ = '0'\n\ndef _helper():\n    return 1\n")
    (pkg / "model" / "b.py").write_text("def f():\n    from .a import _helper\n    return _helper()\n")
    monkeypatch.setitem(globals(), "PACKAGE", pkg)
    assert _private_name_imports() == ["loopsolve.model.b imports _helper from loopsolve.model.a"]
