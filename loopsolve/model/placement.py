"""Where the vectors of a model sit: each vector's tail as a signed sum of vectors from the origin.

A vector loop says how vectors add up, not where they are. The points of interest (sums of
vectors from the origin) and the textbook convention that a loop starts at the origin, or at a
vector another loop already placed, fix the ends of the vectors (a constant vector in no loop, a frame
vector such as ``r0 = { x = "x0", y = "y0" }``, is walked first wherever a point's sum names it: a sum
is the same in any order, so ``"r2 + r0"`` places the crank at the frame as ``"r0 + r2"`` does, as
the drawing's skeleton does): that is what a drawing shows
(:mod:`loopsolve.output.geometry` places them the same way) and what the higher pairs need (a slot
along a vector passes through its tail; a gear turns about a pivot of its link).

:func:`placement` returns, for every vector it can place, the signed terms of its tail and head
from the origin; :func:`link_vectors` the vectors that turn rigidly with one angle variable (the
bars of that link).
"""

from __future__ import annotations

from dataclasses import dataclass

from . import expr as _expr

__all__ = ["Placement", "placement", "link_vectors"]


@dataclass(frozen=True)
class Placement:
    """``tail[v]`` and ``head[v]``: tuples of ``(sign, vector)`` summing to the vector's ends (from the origin)."""

    tail: dict
    head: dict


class _Nodes:
    def __init__(self):
        self.parent: dict = {}

    def find(self, a):
        self.parent.setdefault(a, a)
        while self.parent[a] != a:
            self.parent[a] = self.parent[self.parent[a]]
            a = self.parent[a]
        return a

    def union(self, a, b):
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            if rb == "origin":
                ra, rb = rb, ra
            self.parent[rb] = ra


def _walk(loop) -> tuple:
    """The closed path of a loop: the left side forward, then the right side backward."""
    if loop.rhs:
        return tuple(loop.lhs) + tuple((-s, n) for s, n in reversed(loop.rhs))
    return tuple(loop.terms)


def placement(mech) -> Placement:
    """The ends of every vector that the points and loops place (see the module notes)."""
    nodes = _Nodes()
    nodes.find("origin")
    placed: set = set()

    def chain(start, seq):
        cur = start
        for sign, v in seq:
            enter, leave = (("tail", v), ("head", v)) if sign > 0 else (("head", v), ("tail", v))
            if cur is not None:
                nodes.union(cur, enter)
            cur = leave
            placed.add(v)
        return cur

    frame = _frame_vectors(mech)
    for p in mech.points:  # points are sums from the origin: they say where their vectors are
        if p.plain and p.terms:
            chain("origin", sorted(p.terms, key=lambda t: t[1] not in frame))
    pending = list(mech.loops)
    while pending:
        pick = next((lp for lp in pending if any(v in placed for _, v in _walk(lp))), pending[0])
        pending.remove(pick)
        seq = _walk(pick)
        hit = next((i for i, (_, v) in enumerate(seq) if v in placed), None)
        if hit is None:  # a loop no earlier one touches starts at the origin
            end = chain("origin", seq)
            nodes.union(end, "origin")
        else:  # start the walk at a vector already placed: rotate the closed walk to begin there
            seq = seq[hit:] + seq[:hit]
            first = ("tail", seq[0][1]) if seq[0][0] > 0 else ("head", seq[0][1])
            end = chain(None, seq)
            nodes.union(end, first)
    # the position of every node reached from the origin along vectors
    edges: dict = {}
    for v in placed:
        a, b = nodes.find(("tail", v)), nodes.find(("head", v))
        edges.setdefault(a, []).append((b, 1, v))
        edges.setdefault(b, []).append((a, -1, v))
    pos = {nodes.find("origin"): ()}
    frontier = [nodes.find("origin")]
    while frontier:
        n = frontier.pop(0)
        for m, sign, v in edges.get(n, ()):
            if m not in pos:
                pos[m] = pos[n] + ((sign, v),)
                frontier.append(m)
    tail, head = {}, {}
    for v in placed:
        a, b = nodes.find(("tail", v)), nodes.find(("head", v))
        if a in pos and b in pos:
            tail[v], head[v] = pos[a], pos[b]
    return Placement(tail, head)


def _frame_vectors(mech) -> set:
    """The constant vectors that are in no loop (they carry the frame: walked first in a point's sum)."""
    variables = {v.name for v in mech.variables}
    in_loops = {name for loop in mech.loops for _, name in loop.terms}
    out = set()
    for v in mech.vectors:
        nodes = (v.x, v.y) if v.cartesian else (v.length, v.angle, v.offset)
        used = set().union(*(_expr.names(n) for n in nodes if n is not None))
        if not used & variables and v.name not in in_loops:
            out.add(v.name)
    return out


def link_vectors(mech, angle: str) -> list[str]:
    """The vectors that turn with the variable ``angle`` alone and keep their length: the bars of its link."""
    variables = {v.name for v in mech.variables}
    out = []
    for v in mech.vectors:
        if v.cartesian:
            continue
        avars = (_expr.names(v.angle) | (_expr.names(v.offset) if v.offset is not None else set())) & variables
        if avars == {angle} and not (_expr.names(v.length) & variables):
            out.append(v.name)
    return out
