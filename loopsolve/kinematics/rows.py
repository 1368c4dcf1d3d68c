"""The output rows of a traced sweep: their solution (positions, mode codes, residuals,
iterations), filled from the path's nodes where a row is one, solved by the tracer elsewhere.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .results import Event, EventKind

if TYPE_CHECKING:  # annotations only: continuation imports this module
    from .continuation import Path, Tracer


class RowSolution:
    """Positions of the rows (``Z`` (nvar, N)) with their mode codes, residuals, iterations, and
    which rows could be solved (``ok``); ``sigs`` lists the signature of each code."""

    def __init__(self, n, nv):
        self.Z = np.empty((nv, n))
        self.code = np.zeros(n, dtype=np.int64)
        self.res = np.zeros(n)
        self.its = np.zeros(n, dtype=np.int64)
        self.ok = np.ones(n, dtype=bool)
        self.sigs: list[str] = []
        self._codes: dict[str, int] = {}
        self.events: list[Event] = []
        self.J = None  # raw Jacobians (n*n, N) where known (batched path)
        self.J_ok = None

    def code_of(self, sig: str) -> int:
        c = self._codes.get(sig)
        if c is None:
            c = self._codes[sig] = len(self.sigs)
            self.sigs.append(sig)
        return c



def fill_node_rows(path: Path, rows, sol: RowSolution) -> np.ndarray:
    """Rows that are path nodes: copy them. Returns the mask of the other rows."""
    is_node = rows.node >= 0
    if is_node.any():
        nodes = path.nodes
        mark = np.zeros(len(nodes), dtype=bool)
        mark[rows.node[is_node]] = True
        used = np.flatnonzero(mark)
        pos = np.full(len(nodes), -1, dtype=np.int64)
        pos[used] = np.arange(len(used))
        NZ = np.array([nodes[i].z for i in used], dtype=float)
        ref = pos[rows.node[is_node]]
        sol.Z[:, is_node] = NZ[ref].T
        sol.res[is_node] = np.array([nodes[i].residual for i in used])[ref]
        sol.its[is_node] = np.array([nodes[i].n_iter for i in used], dtype=np.int64)[ref]
        sol.code[is_node] = np.array([sol.code_of(nodes[i].sig) for i in used], dtype=np.int64)[ref]
    return ~is_node



def solve_rows_scalar(tracer: Tracer, path: Path, rows, g, sol: RowSolution, which) -> None:
    """Solve the given rows one by one with the tracker's corrector on their segment."""
    for r in which:
        seg = int(rows.seg[r])
        kk = int(rows.ks[r])
        a, b = path.nodes[seg], path.nodes[seg + 1]
        s = path.seg_sig[seg]
        res = tracer.solve_at(a, b, g.value(kk), s)
        sol.code[r] = sol.code_of(s)
        if res is None:
            x = tracer._display(g.value(kk))
            sol.events.append(Event(EventKind.SINGULAR, x, f"no converged solution on mode {s}; row left out"))
            sol.ok[r] = False
            continue
        z, rr, it = res
        sol.Z[:, r] = z
        sol.res[r] = rr
        sol.its[r] = it
