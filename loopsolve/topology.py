"""Structure of the equations: the solve order (block decomposition) of Φ.

The incidence of unknowns in equations is a bipartite graph. A maximum matching assigns
each equation an unknown it solves for; the strongly connected components of the resulting
dependency graph, in topological order, are the smallest blocks that can be solved one after
the other (Dulmage–Mendelsohn / Tarjan ordering). A Watt six-bar splits into two 2×2 blocks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import networkx as nx

from .errors import TopologyError

__all__ = ["Block", "solve_order"]


@dataclass(frozen=True, slots=True)
class Block:
    """Equations ``eqs`` (row indices of Φ) solved together for ``unknowns`` (column indices of Φ_q)."""

    eqs: tuple[int, ...]
    unknowns: tuple[int, ...]


def solve_order(incidence: Sequence[Sequence[bool]], *, unknown_names: Sequence[str] = (),
                equation_names: Sequence[str] = ()) -> tuple[Block, ...]:
    """Split a square system into blocks solved in sequence.

    Parameters
    ----------
    incidence : m × n booleans
        ``incidence[i][j]`` is true when unknown ``j`` appears in equation ``i``.

    Returns
    -------
    tuple of Block, in solve order.

    Raises
    ------
    TopologyError
        When no perfect matching exists (some unknowns cannot be determined by the equations).

    Examples
    --------
    >>> [b.unknowns for b in ls.topology.solve_order([[1, 1, 0, 0], [1, 1, 0, 0],
    ...                                                [1, 0, 1, 1], [0, 1, 1, 1]])]
    [(0, 1), (2, 3)]
    """
    m = len(incidence)
    n = len(incidence[0]) if m else 0
    unames = list(unknown_names) or [f"q{j}" for j in range(n)]
    enames = list(equation_names) or [f"eq{i}" for i in range(m)]
    if m != n:
        raise TopologyError(f"{m} equations for {n} unknowns: the system is not square")
    g = nx.Graph()
    eq_nodes = [("e", i) for i in range(m)]
    un_nodes = [("u", j) for j in range(n)]
    g.add_nodes_from(eq_nodes, bipartite=0)
    g.add_nodes_from(un_nodes, bipartite=1)
    for i in range(m):
        for j in range(n):
            if incidence[i][j]:
                g.add_edge(("e", i), ("u", j))
    matching = nx.bipartite.hopcroft_karp_matching(g, top_nodes=eq_nodes)
    unmatched = [unames[j] for j in range(n) if ("u", j) not in matching]
    if unmatched:
        free_eqs = [enames[i] for i in range(m) if ("e", i) not in matching]
        raise TopologyError(
            "the loop equations cannot determine the unknown(s) " + ", ".join(unmatched)
            + (f" (equations {', '.join(free_eqs)} over-determine the rest)" if free_eqs else "")
            + ": check which vectors carry these variables"
        )
    # dependency graph on equations: eq i (solving u(i)) depends on the eqs that solve the other unknowns in it
    solves = {i: matching[("e", i)][1] for i in range(m)}
    solver_of = {u: i for i, u in solves.items()}
    d = nx.DiGraph()
    d.add_nodes_from(range(m))
    for i in range(m):
        for j in range(n):
            if incidence[i][j] and j != solves[i]:
                d.add_edge(solver_of[j], i)
    cond = nx.condensation(d)
    blocks = []
    for c in nx.lexicographical_topological_sort(cond, key=lambda c: min(cond.nodes[c]["members"])):
        eqs = tuple(sorted(cond.nodes[c]["members"]))
        blocks.append(Block(eqs, tuple(sorted(solves[i] for i in eqs))))
    return tuple(blocks)
