"""Design spaces: grids, seeded random samples and Latin hypercubes of parameter values.

A design is one set of values of the varied parameters (model units: the numbers of the
model file). :func:`parse_vary` reads the command line's ``--vary`` values
(``name=start:stop:count`` or ``name=v1,v2,...``); :func:`grid`, :func:`sample` and
:func:`latin_hypercube` turn ranges into a :class:`Designs` table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError

__all__ = ["Designs", "parse_vary", "grid", "sample", "latin_hypercube", "designs_from", "design_count",
           "design_problems", "MAX_DESIGNS"]

#: default cap on the number of designs of one study (``max_designs=``, ``--max-designs``)
MAX_DESIGNS = 100_000


def _too_many(count, max_designs: int, what: str) -> ModelError:
    shown = f"{count:,}" if count < 10**15 else f"{float(count):.3g}"
    return ModelError(f"{what} gives {shown} designs, more than the limit of {max_designs:,}: use fewer values, "
                      "or raise the limit with --max-designs (max_designs=)")


@dataclass(frozen=True, eq=False)
class Designs:
    """A table of designs: ``values[name]`` is an array of length ``len(self)``.

    Examples
    --------
    >>> d = grid({"r2": [20, 30], "r3": [60, 70, 80]})
    >>> len(d), d.names, d.row(1)
    (6, ('r2', 'r3'), {'r2': 20.0, 'r3': 70.0})
    """

    names: tuple[str, ...]
    values: Mapping[str, np.ndarray]

    def __len__(self) -> int:
        return len(next(iter(self.values.values()))) if self.names else 0

    def row(self, i: int) -> dict[str, float]:
        """The parameter values of design ``i``."""
        return {n: float(self.values[n][i]) for n in self.names}

    def slice(self, a: int, b: int) -> "Designs":
        return Designs(self.names, {n: self.values[n][a:b] for n in self.names})


def _number(text: str, name: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ModelError(f"--vary {name}: {text!r} is not a number") from None
    if not math.isfinite(v):
        raise ModelError(f"--vary {name}: {text!r} is not a finite number")
    return v


def parse_vary(text: str, *, max_count: int | None = None) -> tuple[str, object]:
    """One ``--vary`` value: ``name=start:stop:count`` (a range) or ``name=v1,v2,...`` (a list).

    Returns ``(name, values)``: a list for a list or a range with a count, or a
    ``(low, high)`` box (a tuple) for ``name=low:high`` (for ``--samples``/``--lhs``). A COUNT
    above ``max_count`` is refused before any value is made.

    Examples
    --------
    >>> parse_vary("r2=20:40:3")
    ('r2', [20.0, 30.0, 40.0])
    >>> parse_vary("r3=60,70")
    ('r3', [60.0, 70.0])
    >>> parse_vary("r4=40:50")
    ('r4', (40.0, 50.0))
    """
    name, sep, rest = text.partition("=")
    name = name.strip()
    if not sep or not name or not rest.strip():
        raise ModelError(f"--vary {text!r}: expected NAME=START:STOP:COUNT, NAME=LOW:HIGH or NAME=V1,V2,...")
    rest = rest.strip()
    if ":" in rest:
        parts = rest.split(":")
        if len(parts) == 2:
            lo, hi = (_number(p, name) for p in parts)
            return name, (lo, hi)
        if len(parts) != 3:
            raise ModelError(f"--vary {text!r}: a range is START:STOP:COUNT (or LOW:HIGH for a sample)")
        lo, hi = _number(parts[0], name), _number(parts[1], name)
        try:
            count = int(parts[2])
        except ValueError:
            raise ModelError(f"--vary {text!r}: COUNT {parts[2]!r} is not a whole number") from None
        if count < 1:
            raise ModelError(f"--vary {text!r}: COUNT must be at least 1")
        if max_count is not None and count > max_count:
            raise _too_many(count, max_count, f"--vary {text}")
        return name, np.linspace(lo, hi, count).tolist()
    return name, [_number(p.strip(), name) for p in rest.split(",") if p.strip()]


def _grid_axes(axes: Mapping[str, Sequence[float]]) -> list[np.ndarray]:
    arrays = []
    for n in axes:
        v = axes[n]
        if isinstance(v, tuple) and len(v) == 2 and not isinstance(v[0], (list, tuple, np.ndarray)):
            raise ModelError(f"--vary {n}={v[0]}:{v[1]}: give a COUNT (START:STOP:COUNT) for a grid, "
                             "or use --samples/--lhs to sample the box")
        a = np.atleast_1d(np.asarray(v, dtype=float))
        if a.size == 0:
            raise ModelError(f"--vary {n}: no values")
        arrays.append(a.ravel())
    return arrays


def grid(axes: Mapping[str, Sequence[float]], *, max_designs: int = MAX_DESIGNS) -> Designs:
    """Cartesian product of value lists (the last name varies fastest).

    The product of the lengths is counted (exactly, as an integer) before the grid is made:
    more than ``max_designs`` designs is a ModelError.
    """
    names = tuple(axes)
    if not names:
        raise ModelError("a design study needs at least one varied parameter (--vary NAME=...)")
    arrays = _grid_axes(axes)
    count = math.prod(len(a) for a in arrays)
    if count > max_designs:
        raise _too_many(count, max_designs, "the grid of --vary values (" + " × ".join(
            f"{len(a)} {n}" for n, a in zip(names, arrays)) + ")")
    mesh = np.meshgrid(*arrays, indexing="ij")
    return Designs(names, {n: m.ravel().copy() for n, m in zip(names, mesh)})


def _box(axes: Mapping[str, object]) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    names = tuple(axes)
    if not names:
        raise ModelError("a design study needs at least one varied parameter (--vary NAME=LOW:HIGH)")
    lo, hi = [], []
    for n in names:
        a = np.asarray(axes[n], dtype=float).ravel()
        if a.size != 2:
            raise ModelError(f"--vary {n}: --samples/--lhs draw designs from a box LOW:HIGH, got {a.size} "
                             f"value(s); a grid's COUNT or a list of values is not used by a sample: give "
                             f"{n}=LOW:HIGH (in Python a pair (low, high))")
        lo.append(float(a.min()))
        hi.append(float(a.max()))
    return names, np.array(lo), np.array(hi)


def sample(axes: Mapping[str, object], n: int, seed: int | None = 0, *, max_designs: int = MAX_DESIGNS) -> Designs:
    """``n`` designs drawn uniformly from the box spanned by each name's values (seeded).

    Examples
    --------
    >>> d = sample({"r2": (20, 40), "r3": (60, 80)}, 5, seed=1)
    >>> len(d), bool(np.all((d.values["r2"] >= 20) & (d.values["r2"] <= 40)))
    (5, True)
    """
    if n < 1:
        raise ModelError(f"--samples {n}: must be at least 1")
    if n > max_designs:
        raise _too_many(n, max_designs, f"--samples {n}")
    names, lo, hi = _box(axes)
    u = np.random.default_rng(seed).random((n, len(names)))
    x = lo + u * (hi - lo)
    return Designs(names, {nm: x[:, j].copy() for j, nm in enumerate(names)})


def latin_hypercube(axes: Mapping[str, object], n: int, seed: int | None = 0, *,
                    max_designs: int = MAX_DESIGNS) -> Designs:
    """``n`` designs of a Latin hypercube of the box (scipy's ``qmc.LatinHypercube``, seeded).

    Examples
    --------
    >>> d = latin_hypercube({"r2": (0, 10)}, 10, seed=0)
    >>> sorted(np.floor(d.values["r2"]).astype(int).tolist())
    [0, 1, 2, 3, 4, 5, 6, 7, 8, 9]
    """
    if n < 1:
        raise ModelError(f"--lhs {n}: must be at least 1")
    if n > max_designs:
        raise _too_many(n, max_designs, f"--lhs {n}")
    from scipy.stats import qmc

    names, lo, hi = _box(axes)
    u = qmc.LatinHypercube(d=len(names), seed=seed).random(n)
    x = lo + u * (hi - lo)
    return Designs(names, {nm: x[:, j].copy() for j, nm in enumerate(names)})


def design_count(spec, *, samples: int | None = None, lhs: int | None = None) -> int:
    """How many designs :func:`designs_from` would make, counted without making them."""
    if isinstance(spec, Designs):
        return len(spec)
    if samples is not None:
        return int(samples)
    if lhs is not None:
        return int(lhs)
    return math.prod(len(a) for a in _grid_axes(spec)) if spec else 0


def designs_from(spec, *, samples: int | None = None, lhs: int | None = None, seed: int | None = 0,
                 max_designs: int = MAX_DESIGNS) -> Designs:
    """A :class:`Designs` from a mapping of values/boxes (grid by default), or a Designs as is.

    More than ``max_designs`` designs is a ModelError, raised before any design is made.
    """
    if isinstance(spec, Designs):
        if len(spec) > max_designs:
            raise _too_many(len(spec), max_designs, "the Designs table")
        return spec
    if samples is not None and lhs is not None:
        raise ModelError("give either --samples or --lhs, not both")
    if samples is not None:
        return sample(spec, samples, seed, max_designs=max_designs)
    if lhs is not None:
        return latin_hypercube(spec, lhs, seed, max_designs=max_designs)
    return grid(spec, max_designs=max_designs)


def _eval_array(node, env):
    """A length expression (numbers, names, + - * / **, unary minus) on arrays of designs."""
    from ..model import expr as _expr

    if isinstance(node, _expr.Num):
        return float(node.value)
    if isinstance(node, _expr.Name):
        return env[node.id]
    if isinstance(node, _expr.Unary):
        v = _eval_array(node.operand, env)
        return -v if node.op == "-" else v
    a, b = _eval_array(node.left, env), _eval_array(node.right, env)
    return {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide, "**": np.power}[node.op](a, b)


def design_problems(mech, names: Sequence[str], values: np.ndarray) -> np.ndarray:
    """Why each design is not a design of ``mech`` ('' when it is one): the model file's checks.

    ``values`` ``(D, len(names))`` in model units. A design is refused as its model file would
    be: a varied value that is not finite or beyond ±``MAX_MAGNITUDE`` (lengths), and a link (a
    vector with a moving angle and a constant length) whose length is zero or negative (a
    negative crank is the crank turned by 180°, a zero one is no crank). Evaluated on all designs
    at once.

    Examples
    --------
    >>> mech = ls.fourbar(60, 25, 70, 45)
    >>> design_problems(mech, ("r2",), np.array([[25.0], [0.0]])).tolist()[1][:44]
    'the link r2 (angle theta2) has length r2 = 0'
    """
    from ..model import expr as _expr
    from ..model.spec import checked_links, link_length_problem
    from ..model.units import MAX_MAGNITUDE, Kind

    values = np.asarray(values, dtype=float).reshape(-1, len(names))
    D = values.shape[0]
    out = np.array([""] * D, dtype=object)
    kinds = {p.name: p.kind for p in mech.parameters}
    env = {p.name: np.full(D, p.value) for p in mech.parameters if p.kind is not Kind.ANGLE}
    for j, n in enumerate(names):
        v = values[:, j]
        if n in env:
            env[n] = v
        bad = ~np.isfinite(v) | ((kinds.get(n) is not Kind.ANGLE) & (np.abs(v) > MAX_MAGNITUDE))
        for d in np.flatnonzero(bad & (out == "")):
            out[d] = (f"{n} = {v[d]:g}: not a finite number" if not math.isfinite(v[d]) else
                      f"{n} = {v[d]:g} is beyond ±{MAX_MAGNITUDE:g} (values that large overflow the solver's squares)")
    from ..model.gears import teeth_parameters

    for j, n in enumerate(names):  # tooth numbers are whole numbers, at least 1
        if n in teeth_parameters(mech):
            v = values[:, j]
            for d in np.flatnonzero(((v < 1) | (np.abs(v - np.rint(v)) > 1e-9)) & (out == "")):
                out[d] = f"{n} = {v[d]:g}: a number of teeth is a whole number, at least 1"
    varied = set(names)
    for vec in checked_links(mech.vectors, mech.parameters, mech.variables):
        used = _expr.names(vec.length) & varied
        if not used:
            continue  # the model file's own check holds for every design
        with np.errstate(all="ignore"):
            length = np.broadcast_to(np.asarray(_eval_array(vec.length, env), dtype=float), (D,))
        for d in np.flatnonzero(~(length > 0) & (out == "")):
            why = link_length_problem(vec, float(length[d]))
            if not isinstance(vec.length, _expr.Name):  # name the varied values the length is made of
                why = ", ".join(f"{n} = {values[d, list(names).index(n)]:g}" for n in names if n in used) + ": " + why
            out[d] = why
    return out
