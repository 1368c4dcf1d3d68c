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

from .errors import ModelError

__all__ = ["Designs", "parse_vary", "grid", "sample", "latin_hypercube", "designs_from"]


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


def parse_vary(text: str) -> tuple[str, object]:
    """One ``--vary`` value: ``name=start:stop:count`` (a range) or ``name=v1,v2,...`` (a list).

    Returns ``(name, values)``: an array for a list or a range with a count, or a
    ``(low, high)`` box for ``name=low:high`` (for ``--samples``/``--lhs``).

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
        return name, np.linspace(lo, hi, count).tolist()
    return name, [_number(p.strip(), name) for p in rest.split(",") if p.strip()]


def grid(axes: Mapping[str, Sequence[float]]) -> Designs:
    """Cartesian product of value lists (the last name varies fastest)."""
    names = tuple(axes)
    if not names:
        raise ModelError("a design study needs at least one varied parameter (--vary NAME=...)")
    arrays = []
    for n in names:
        v = axes[n]
        if isinstance(v, tuple) and len(v) == 2 and not isinstance(v[0], (list, tuple, np.ndarray)):
            raise ModelError(f"--vary {n}={v[0]}:{v[1]}: give a COUNT (START:STOP:COUNT) for a grid, "
                             "or use --samples/--lhs to sample the box")
        a = np.atleast_1d(np.asarray(v, dtype=float))
        if a.size == 0:
            raise ModelError(f"--vary {n}: no values")
        arrays.append(a)
    mesh = np.meshgrid(*arrays, indexing="ij")
    return Designs(names, {n: m.ravel().copy() for n, m in zip(names, mesh)})


def _box(axes: Mapping[str, object]) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    names = tuple(axes)
    if not names:
        raise ModelError("a design study needs at least one varied parameter (--vary NAME=LOW:HIGH)")
    lo, hi = [], []
    for n in names:
        a = np.asarray(axes[n], dtype=float).ravel()
        if a.size == 0:
            raise ModelError(f"--vary {n}: no values")
        lo.append(float(a.min()))
        hi.append(float(a.max()))
    return names, np.array(lo), np.array(hi)


def sample(axes: Mapping[str, object], n: int, seed: int | None = 0) -> Designs:
    """``n`` designs drawn uniformly from the box spanned by each name's values (seeded).

    Examples
    --------
    >>> d = sample({"r2": (20, 40), "r3": (60, 80)}, 5, seed=1)
    >>> len(d), bool(np.all((d.values["r2"] >= 20) & (d.values["r2"] <= 40)))
    (5, True)
    """
    if n < 1:
        raise ModelError(f"--samples {n}: must be at least 1")
    names, lo, hi = _box(axes)
    u = np.random.default_rng(seed).random((n, len(names)))
    x = lo + u * (hi - lo)
    return Designs(names, {nm: x[:, j].copy() for j, nm in enumerate(names)})


def latin_hypercube(axes: Mapping[str, object], n: int, seed: int | None = 0) -> Designs:
    """``n`` designs of a Latin hypercube of the box (scipy's ``qmc.LatinHypercube``, seeded).

    Examples
    --------
    >>> d = latin_hypercube({"r2": (0, 10)}, 10, seed=0)
    >>> sorted(np.floor(d.values["r2"]).astype(int).tolist())
    [0, 1, 2, 3, 4, 5, 6, 7, 8, 9]
    """
    if n < 1:
        raise ModelError(f"--lhs {n}: must be at least 1")
    from scipy.stats import qmc

    names, lo, hi = _box(axes)
    u = qmc.LatinHypercube(d=len(names), seed=seed).random(n)
    x = lo + u * (hi - lo)
    return Designs(names, {nm: x[:, j].copy() for j, nm in enumerate(names)})


def designs_from(spec, *, samples: int | None = None, lhs: int | None = None, seed: int | None = 0) -> Designs:
    """A :class:`Designs` from a mapping of values/boxes (grid by default), or a Designs as is."""
    if isinstance(spec, Designs):
        return spec
    if samples is not None and lhs is not None:
        raise ModelError("give either --samples or --lhs, not both")
    if samples is not None:
        return sample(spec, samples, seed)
    if lhs is not None:
        return latin_hypercube(spec, lhs, seed)
    return grid(spec)
