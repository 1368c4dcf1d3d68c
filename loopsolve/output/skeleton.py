"""The skeleton of a vector-loop model's diagram: which vector ends meet, what is ground, link or slider,
and where every node is at a solved pose (numpy only; :mod:`loopsolve.output.geometry` dresses it).

Where things are comes from the solve: every named point's node sits at the point's solved
coordinates (the numbers ``solve`` prints), and the other nodes are reached from the nearest
such anchor (or the origin) along the vectors. Which ends meet comes from the declarations:

* a loop is a closed chain of its vectors (the left side forward, the right side backward),
  placed wherever the points put it; only a loop that no point places starts at the origin
  (a model without points);
* a point is a walk from the origin along its whole vectors (``O2 = "r0"``, ``A = "r0 + r2"``):
  its node is the end of its last vector. A constant vector that is in no loop (a frame vector
  such as ``r0 = { x = "x0", y = "y0" }``) is walked first wherever the sum names it, so
  ``"r2 + r0"`` places the crank at the frame as ``"r0 + r2"`` does, unless that contradicts
  what other points already placed (then the written order is walked);
* a point with factors (``"r0 + r2 + rcx*u3 + rcy*n3"``) walks its whole vectors; when the
  rest turns with one link (constant lengths, the link's angle variables) it is a rigid point
  of that link (a vertex of its outline), else a free point drawn where the solve puts it;
* every join is checked at the first solved pose (positions and velocities): a declaration
  that uses one vector in two places cannot pull a drawn joint away from the solve.

A vector whose length and angle depend on no variable is *ground* when one of its ends is fixed
(the origin is); a vector whose angle depends on variables and whose length is constant is part of
a *link*, the same link as the vectors turning with the same variables; a vector whose length is a
variable is a *slider* (a block at its tip, or further along constant offsets where a link is
pinned), a *rotating slider* (a slotted lever) when its angle varies too.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

__all__: list[str] = []


class _Nodes:
    """Union-find over vector ends (``("tail", v)``, ``("head", v)``), ``"origin"`` and walk marks."""

    def __init__(self):
        self.parent: dict = {}

    def copy(self) -> "_Nodes":
        out = _Nodes()
        out.parent = dict(self.parent)
        return out

    def find(self, k):
        self.parent.setdefault(k, k)
        while self.parent[k] != k:
            self.parent[k] = self.parent[self.parent[k]]
            k = self.parent[k]
        return k

    def union(self, a, b):
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            # keep "origin" as the representative when present
            if rb == "origin":
                ra, rb = rb, ra
            self.parent[rb] = ra


class _Placement:
    """Where the ends of the vectors sit relative to each other at one solved pose: a union-find whose
    members carry their offset (position and velocity, ``(4,)``) from their set's root.

    :meth:`relate` records that one member is at a given offset from another, and refuses (records
    nothing) when that contradicts what is known at the pose. Infinite tolerances accept everything
    (no pose to check against).
    """

    def __init__(self, tol_p: float, tol_v: float):
        self.parent: dict = {}
        self.off: dict = {}
        self.tol_p, self.tol_v = tol_p, tol_v

    def copy(self) -> "_Placement":
        out = _Placement(self.tol_p, self.tol_v)
        out.parent, out.off = dict(self.parent), dict(self.off)
        return out

    def find(self, k):
        if k not in self.parent:
            self.parent[k], self.off[k] = k, np.zeros(4)
        path = []
        while self.parent[k] != k:
            path.append(k)
            k = self.parent[k]
        acc = np.zeros(4)
        for n in reversed(path):  # offsets to the root, nearest the root first
            acc = acc + self.off[n]
            self.off[n], self.parent[n] = acc, k
        return k, (self.off[path[0]] if path else np.zeros(4))

    def relate(self, a, b, d) -> bool:
        """Record ``place(b) = place(a) + d``; False (nothing recorded) when that contradicts what is known."""
        ra, oa = self.find(a)
        rb, ob = self.find(b)
        if ra == rb:
            if not np.isfinite(d[:2]).all():
                return True  # no pose to check against
            gap = ob - oa - d
            if not (np.abs(gap[:2]) <= self.tol_p).all():
                return False
            return bool(not np.isfinite(gap[2:]).all() or (np.abs(gap[2:]) <= self.tol_v).all())
        if rb == "origin":  # keep the origin a root
            ra, rb, oa, ob, d = rb, ra, ob, oa, -d
        self.parent[rb] = ra
        self.off[rb] = np.nan_to_num(oa + d - ob)
        return True

    def same_set(self, a, b) -> bool:
        return self.find(a)[0] == self.find(b)[0]


def _walk_sequence(loop) -> tuple[tuple[int, str], ...]:
    """The closed path of a loop: the left side forward, then the right side backward."""
    if loop.rhs:
        return tuple(loop.lhs) + tuple((-s, n) for s, n in reversed(loop.rhs))
    return tuple(loop.terms)


def _ends(sign: int, v: str):
    """The end of ``v`` a walk enters and the end it leaves (``sign`` < 0: walked backwards)."""
    return (("tail", v), ("head", v)) if sign > 0 else (("head", v), ("tail", v))


@dataclass
class Structure:
    """Pose-independent structure of a mechanism's diagram (from its vectors, loops and points)."""

    node_of: dict  # (end, vec) -> node id
    kind: dict  # vec -> "ground" | "bar" | "slider" | "rslider" | "offset" | "moving"
    link_of: dict  # vec -> link key (bars, rotating sliders)
    fixed: set  # fixed node ids
    point_node: dict  # point name -> node id (a vector end, or ("point", name) for a rigid point of a link)
    names: dict  # node id -> label
    vectors: tuple  # placed vectors in compiled order
    links: dict = field(default_factory=dict)  # link key -> list of node ids (declared order)
    blocks: list = field(default_factory=list)  # (slider vec, node id of the block)
    joints: set = field(default_factory=set)  # nodes drawn as joints (links' pins, blocks, ground pivots)
    ground: list = field(default_factory=list)  # fixed vectors drawn as frame lines
    roots: list = field(default_factory=list)  # (node, anchor): "origin", ("point", j), ("sum", terms) or None
    tree: list = field(default_factory=list)  # (node, parent node, vec, sign): node = parent + sign * vec


def _displacements(ck, z, z1=None) -> np.ndarray:
    """``(V, 4)``: every vector's components and their rates at the pose ``z`` (rates NaN without ``z1``)."""
    vv = ck.vector_values(0, z)
    L, a = vv[:, 0], vv[:, 1]
    c, s = np.cos(a), np.sin(a)
    out = np.full((len(L), 4), np.nan)
    out[:, 0], out[:, 1] = L * c, L * s
    if z1 is not None:
        with np.errstate(all="ignore"):
            d = ck.vector_values(1, z, z1)
            out[:, 2] = d[:, 0] * c - L * d[:, 1] * s
            out[:, 3] = d[:, 0] * s + L * d[:, 1] * c
    return out


def _reference(ck, states):
    """The first pose of ``states`` with finite variables: what the structure's joins are checked at."""
    for s in states:
        z = np.asarray(s.z, dtype=float)
        if np.isfinite(z).all():
            z1 = np.asarray(s.z1, dtype=float)
            return _displacements(ck, z, z1 if np.isfinite(z1).all() else None)
    return None


def _dependencies(ck):
    """Per vector: the variables its length depends on, and those its angle (or components) depend on."""
    from ..model.expr import names as expr_names

    mech = ck.mechanism
    variables = set(ck.variables)
    lvars, avars = {}, {}
    for v in ck.vectors:
        vc = mech.vector(v)
        if vc.cartesian:
            deps = (expr_names(vc.x) | expr_names(vc.y)) & variables
            lvars[v], avars[v] = deps, deps
        else:
            lvars[v] = expr_names(vc.length) & variables
            avars[v] = (expr_names(vc.angle) | (expr_names(vc.offset) if vc.offset is not None else set())) \
                & variables
    return lvars, avars


class _Walker:
    """Joins vector ends into nodes (checked at the reference pose) as loops and points declare them."""

    def __init__(self, ck, disp):
        self.index = {v: i for i, v in enumerate(ck.vectors)}
        self.disp = disp
        if disp is not None:
            vel = np.abs(disp[:, 2:])
            vscale = float(np.nanmax(vel)) if np.isfinite(vel).any() else 0.0
            self.place = _Placement(1e-7 * ck.scale, 1e-7 * vscale + 1e-12 * ck.scale)
        else:
            self.place = _Placement(math.inf, math.inf)
        self.nodes = _Nodes()
        self.nodes.find("origin")
        self.place.find("origin")
        self.placed: set[str] = set()
        self.anchors: dict = {}

    def _d(self, v) -> np.ndarray:
        return self.disp[self.index[v]] if self.disp is not None else np.full(4, np.nan)

    def vec(self, v) -> None:
        if v not in self.placed:
            self.placed.add(v)
            self.place.relate(("tail", v), ("head", v), self._d(v))

    def join(self, a, b) -> bool:
        if self.place.relate(a, b, np.zeros(4) if self.disp is not None else np.full(4, np.nan)):
            self.nodes.union(a, b)
            return True
        return False

    def loop(self, seq) -> None:
        for _, v in seq:
            self.vec(v)
        for (s0, v0), (s1, v1) in zip(seq, seq[1:] + seq[:1]):
            self.join(_ends(s0, v0)[1], _ends(s1, v1)[0])

    def trial(self, terms) -> bool:
        """Walk ``terms`` on copies; keep the joins (and return True) only when all of them hold."""
        saved = (self.place, self.nodes, set(self.placed))
        self.place, self.nodes = self.place.copy(), self.nodes.copy()
        cur = "origin"
        for sign, v in terms:
            self.vec(v)
            enter, leave = _ends(sign, v)
            if not self.join(cur, enter):
                self.place, self.nodes, self.placed = saved
                return False
            cur = leave
        return True

    def walk(self, name, terms):
        """Walk ``terms`` from the origin; the node reached, or None when the last step is placed elsewhere.

        A step whose vector is already placed elsewhere is skipped: the walk goes on from the place
        its sum has reached (an anchor of the node it meets next)."""
        cur = "origin"
        for k, (sign, v) in enumerate(terms):
            self.vec(v)
            enter, leave = _ends(sign, v)
            if self.join(cur, enter):
                cur = leave
                continue
            cur = ("walk", name, k)
            upto = tuple(terms[:k + 1])
            reached = (sum((sg * self._d(w) for sg, w in upto), np.zeros(4)) if self.disp is not None
                       else np.full(4, np.nan))
            self.place.relate("origin", cur, reached)
            self.anchors[cur] = ("sum", upto)
        return None if isinstance(cur, tuple) and cur[0] == "walk" else cur


def diagram_structure(ck, states=()) -> Structure:
    """The diagram's structure, its joins checked at the first solved pose of ``states`` (see the module)."""
    mech = ck.mechanism
    lvars, avars = _dependencies(ck)
    w = _Walker(ck, _reference(ck, states))
    loops = [_walk_sequence(loop) for loop in mech.loops]
    in_loops = {v for seq in loops for _, v in seq}
    for seq in loops:
        w.loop(seq)

    def frame_vector(v) -> bool:
        return not lvars[v] and not avars[v] and v not in in_loops

    # points: those whose walk is unambiguous first (no frame vector), then the others, each with its
    # frame vectors first when that agrees with what is placed, else in the written order
    walks = []
    for p in mech.points:
        n = len(p.terms)
        lead = [i for i in range(n) if all(p.factor(j) is None for j in range(i + 1))]  # the leading whole vectors
        frame = [i for i in range(n) if p.factor(i) is None and frame_vector(p.terms[i][1])]
        first = frame + [i for i in lead if i not in frame]
        walks.append((bool(frame), p, first, lead))
    point_node, rigid = {}, {}
    for _, p, first, lead in sorted(walks, key=lambda t: t[0]):
        if first != lead and w.trial([p.terms[i] for i in first]):
            walked, cur = first, w.nodes.find(_ends(*p.terms[first[-1]])[1])
        else:
            walked, cur = lead, w.walk(p.name, [p.terms[i] for i in lead])
        if cur is None:
            continue  # a free point: drawn where the solve puts it
        if p.plain:
            point_node[p.name] = cur
        else:
            rigid[p.name] = (cur, tuple(v for i, (_, v) in enumerate(p.terms) if i not in walked))
    # a chain no point places: its loop starts at the origin (a model without points)
    for seq in loops:
        if seq and not w.place.same_set("origin", _ends(*seq[0])[0]):
            w.join("origin", _ends(*seq[0])[0])

    nodes = w.nodes
    vectors = tuple(v for v in ck.vectors if v in w.placed)
    node_of = {(end, v): nodes.find((end, v)) for v in vectors for end in ("tail", "head")}
    point_node = {p: nodes.find(k) for p, k in point_node.items()}
    origin = nodes.find("origin")
    # fixed nodes: the origin and everything reached from it through constant vectors
    fixed = {origin}
    changed = True
    while changed:
        changed = False
        for v in vectors:
            if lvars[v] or avars[v]:
                continue
            a, b = node_of[("tail", v)], node_of[("head", v)]
            if (a in fixed) != (b in fixed):
                fixed.update((a, b))
                changed = True
    kind, link_of, links = {}, {}, {}
    for v in vectors:
        a, b = node_of[("tail", v)], node_of[("head", v)]
        if lvars[v]:
            kind[v] = "rslider" if avars[v] else "slider"
        elif avars[v]:
            kind[v] = "moving" if mech.vector(v).cartesian else "bar"
        else:
            kind[v] = "ground" if a in fixed else "offset"
        if kind[v] in ("bar", "rslider", "moving"):
            key = frozenset(avars[v])
            link_of[v] = key
            members = links.setdefault(key, [])
            for n in (a, b) if kind[v] != "rslider" else (a,):
                if n not in members:
                    members.append(n)
    # a point with factors: a rigid point of the link its offset turns with (or of the frame)
    for name, (start, rest) in rigid.items():
        start = nodes.find(start)
        keys = {frozenset(avars[v]) if not lvars[v] else None for v in rest}
        if len(keys) == 1:
            (key,) = keys
            if key and start in links.get(key, ()):
                links[key].append(("point", name))
                point_node[name] = ("point", name)
            elif key == frozenset() and start in fixed:
                fixed.add(("point", name))
                point_node[name] = ("point", name)
    blocks = _blocks(vectors, node_of, kind, links)
    joints = _joint_nodes(vectors, node_of, link_of, links, fixed, blocks, set(point_node.values()))
    names = _node_names(mech, vectors, node_of, point_node, kind, fixed, links)
    ground = _frame_lines(vectors, node_of, kind, joints | set(point_node.values()) | {b for _, b in blocks})
    anchors = {nodes.find(k): a for k, a in w.anchors.items()}
    roots, tree = _spanning_forest(vectors, node_of, origin, point_node, anchors, ck.points)
    return Structure(node_of, kind, link_of, fixed, point_node, names, vectors, links, blocks, joints, ground,
                      roots, tree)


def _blocks(vectors, node_of, kind, links) -> list:
    """The block of each slider: at its tip, or further along constant offsets where a link is pinned."""
    pinned = {n for members in links.values() for n in members}
    offsets: dict = {}
    for v in vectors:
        if kind[v] == "offset":
            a, b = node_of[("tail", v)], node_of[("head", v)]
            offsets.setdefault(a, []).append(b)
            offsets.setdefault(b, []).append(a)
    blocks = []
    for v in vectors:
        if kind[v] not in ("slider", "rslider"):
            continue
        tip = node_of[("head", v)]
        block = tip
        if kind[v] == "slider" and tip not in pinned:
            seen, frontier = {tip}, [tip]
            while frontier:
                n = frontier.pop(0)
                if n in pinned:
                    block = n
                    break
                for m in offsets.get(n, ()):
                    if m not in seen:
                        seen.add(m)
                        frontier.append(m)
        blocks.append((v, block))
    return blocks


def _joint_nodes(vectors, node_of, link_of, links, fixed, blocks, named) -> set:
    """The nodes drawn as joints: every link's nodes and every block, except a named point of one
    moving link that nothing else touches (a coupler point: a tracer, not a pin)."""
    at_blocks = {b for _, b in blocks}
    out = {n for members in links.values() for n in members} | at_blocks
    touching: dict = {}
    for v in vectors:
        for end in ("tail", "head"):
            touching.setdefault(node_of[(end, v)], set()).add(link_of.get(v, ("vector", v)))
    for n in named:
        keys = [k for k, members in links.items() if n in members]
        if len(keys) == 1 and n not in fixed and n not in at_blocks and touching.get(n, set()) <= {keys[0]}:
            out.discard(n)
    return out


def _frame_lines(vectors, node_of, kind, kept) -> list:
    """The fixed vectors drawn as frame lines: all but the chains that only carry the frame from an
    unnamed place that is not a joint (``r0`` from the origin to the ground pivot ``O2``)."""
    lines = [v for v in vectors if kind[v] == "ground"]
    degree: dict = {}
    for v in vectors:
        for end in ("tail", "head"):
            degree[node_of[(end, v)]] = degree.get(node_of[(end, v)], 0) + 1
    pruned = True
    while pruned:
        pruned = False
        for v in list(lines):
            ends = (node_of[("tail", v)], node_of[("head", v)])
            if any(degree[n] == 1 and n not in kept for n in ends):
                lines.remove(v)
                for n in ends:
                    degree[n] -= 1
                pruned = True
    return lines


def _spanning_forest(vectors, node_of, origin, point_node, anchors, point_names):
    """Roots and a breadth-first tree over the nodes, from the origin and the named points' nodes
    (and the places a walk reached past a vector placed elsewhere)."""
    adj: dict = {}
    for v in vectors:
        a, b = node_of[("tail", v)], node_of[("head", v)]
        adj.setdefault(a, []).append((b, v, 1))
        adj.setdefault(b, []).append((a, v, -1))
    index = {p: j for j, p in enumerate(point_names)}
    sources = [(origin, "origin")] + [(n, ("point", index[p])) for p, n in point_node.items()]
    sources += [(n, a) for n, a in anchors.items() if n in adj]
    roots, tree, seen = [], [], set()

    def grow(frontier):
        while frontier:
            nxt = []
            for n in frontier:
                for m, v, sign in adj.get(n, ()):
                    if m not in seen:
                        seen.add(m)
                        tree.append((m, n, v, sign))
                        nxt.append(m)
            frontier = nxt

    starts = []
    for n, anchor in sources:
        if n not in seen:
            seen.add(n)
            roots.append((n, anchor))
            starts.append(n)
    grow(starts)
    for n in adj:  # a part no anchor reaches (none once the loops are placed): drawn from the origin
        if n not in seen:
            seen.add(n)
            roots.append((n, None))
            grow([n])
    return roots, tree


def _node_names(mech, vectors, node_of, point_node, kind, fixed, links) -> dict:
    """Labels: point names first, then names read off vector names (``rAB``: A→B, ``r2``: O2)."""
    names: dict = {}
    for p, n in point_node.items():
        names.setdefault(n, p)
    for v in vectors:
        m = re.fullmatch(r"r_?([A-Z][0-9]*)([A-Z][0-9]*)", v)
        if m:
            names.setdefault(node_of[("tail", v)], m.group(1))
            names.setdefault(node_of[("head", v)], m.group(2))
    pivots = {n for key, members in links.items() for n in members} & fixed
    taken = set(names.values())
    for v in vectors:
        if kind[v] not in ("bar", "rslider"):
            continue
        for end in ("tail", "head"):
            n = node_of[(end, v)]
            if n in pivots and n not in names:
                m = re.fullmatch(r"[a-zA-Z]+_?([0-9]+[a-z]*)", v)
                label = f"O{m.group(1)}" if m else f"O({v})"
                if label not in taken:
                    names[n] = label
                    taken.add(label)
    return names


def node_positions(st: Structure, ck, s):
    """Node id → (x, y) at the solved pose ``s`` (model units), and the placed vectors' components.

    Every named point's node is at the point's solved coordinates (the numbers ``solve`` prints);
    the other nodes are reached from the nearest of those (or the origin) along the vectors."""
    disp = _displacements(ck, np.asarray(s.z, dtype=float))[:, :2]
    index = {v: i for i, v in enumerate(ck.vectors)}
    at = np.asarray(s.points[0], dtype=float).reshape(-1, 2)
    pos = {}
    for n, anchor in st.roots:
        if isinstance(anchor, tuple) and anchor[0] == "point":
            pos[n] = at[anchor[1]].copy()
        elif isinstance(anchor, tuple):  # ("sum", terms): where a walk from the origin got to
            pos[n] = sum((sg * disp[index[w]] for sg, w in anchor[1]), np.zeros(2))
        else:
            pos[n] = np.zeros(2)
    for m, n, v, sign in st.tree:
        pos[m] = pos[n] + sign * disp[index[v]]
    return pos, {v: disp[index[v]] for v in st.vectors}
