"""Structure: links and joints, mobility, independent loops, and the solve order of Φ.

Two graphs describe a mechanism's structure.

*The link–joint graph.* Links (the ground and the moving bodies) and joints (revolute R,
prismatic P) are the two node kinds of a bipartite :mod:`networkx` graph; an edge says a link
carries a joint. It gives the Gruebler–Kutzbach mobility ``M = 3(n − 1) − 2 j1 − j2`` (a joint
shared by k links counts as k − 1 joints), the connectivity checks, and the independent loops
(a minimum cycle basis: ``j − n + 1`` loops, the shortest ones, which give the smallest blocks).

*The equation–unknown incidence graph.* The incidence of unknowns in the scalar loop
equations is a bipartite graph. A maximum matching assigns each equation an unknown it solves
for; the strongly connected components of the resulting dependency graph, in topological order,
are the smallest blocks that can be solved one after the other (Dulmage–Mendelsohn / Tarjan
ordering). A Watt six-bar splits into two 2×2 blocks.

The rank of Φ_q (with respect to every joint variable) at an assembly pose is the second opinion
on the mobility: Gruebler's count ignores geometry, so an over-constrained special geometry (a
double parallelogram: Gruebler 0, yet it moves) shows up as a rank deficit.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..errors import ModelError, TopologyError

__all__ = [
    "GROUND",
    "Block",
    "solve_order",
    "RevoluteJoint",
    "PrismaticJoint",
    "Joint",
    "Link",
    "Mobility",
    "Topology",
    "gruebler",
    "jacobian_rank",
    "check_inputs",
]

#: name of the fixed link in a kinematic diagram
GROUND = "ground"

#: maximum number of simple cycles enumerated for the minimum cycle basis
_MAX_CYCLES = 20000


# =============================================================================
# solve order (block decomposition of Φ)
# =============================================================================


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
    import networkx as nx  # lazy: keeps `import loopsolve` light for the CLI

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


# =============================================================================
# declarations: joints and links
# =============================================================================


def _point(value, what: str) -> tuple[float, float]:
    try:
        x, y = value
        out = (float(x), float(y))
    except (TypeError, ValueError):
        raise ModelError(f"{what}: expected two numbers [x, y], got {value!r}") from None
    if not all(math.isfinite(c) for c in out):
        raise ModelError(f"{what}: {value!r} is not a pair of finite numbers")
    return out


def _check_decl_name(name, what: str) -> None:
    if not isinstance(name, str) or not name or not (name[0].isalpha() and name.isascii()) \
            or not all(c.isalnum() or c == "_" for c in name) or "__" in name or name.endswith("_"):
        raise ModelError(f"{what} {name!r}: a name is letters, digits and single underscores, "
                         "starting with a letter and not ending with _")


@dataclass(frozen=True, slots=True)
class RevoluteJoint:
    """A pin (R joint) drawn at ``at`` (model length units) in the assembly pose.

    Examples
    --------
    >>> ls.topology.RevoluteJoint("B", (0, 25))
    RevoluteJoint(name='B', at=(0.0, 25.0))
    """

    name: str
    at: tuple[float, float]

    def __post_init__(self):
        _check_decl_name(self.name, "joint")
        object.__setattr__(self, "at", _point(self.at, f"joint {self.name!r}: at"))

    @property
    def kind(self) -> str:
        return "R"


@dataclass(frozen=True, slots=True)
class PrismaticJoint:
    """A slider (P joint) drawn at ``at``; ``axis`` is the slide direction in the drawn pose.

    The two links it joins keep their relative angle and translate along ``axis``. The line of
    sliding is fixed in the ``guide`` link (default: the ground if it is one of the two, else
    the link with more joints, else the first listed); the joint variable ``s_<joint>`` is the
    position of the slider along the axis, measured from the foot of the perpendicular dropped
    from the guide's reference point (the origin for the ground, else its first joint).
    ``axis`` is normalized to a unit vector.

    Examples
    --------
    >>> ls.topology.PrismaticJoint("S", (80, 0), axis=(2, 0)).axis
    (1.0, 0.0)
    """

    name: str
    at: tuple[float, float]
    axis: tuple[float, float]
    guide: str | None = None

    def __post_init__(self):
        _check_decl_name(self.name, "joint")
        object.__setattr__(self, "at", _point(self.at, f"joint {self.name!r}: at"))
        ax = _point(self.axis, f"joint {self.name!r}: axis")
        norm = math.hypot(*ax)
        if norm == 0.0:
            raise ModelError(f"joint {self.name!r}: the slide axis {self.axis!r} has zero length; give "
                             "the direction of sliding, e.g. axis = [1, 0]")
        object.__setattr__(self, "axis", (ax[0] / norm, ax[1] / norm))
        if self.guide is not None and not isinstance(self.guide, str):
            raise ModelError(f"joint {self.name!r}: guide must be a link name, got {self.guide!r}")

    @property
    def kind(self) -> str:
        return "P"


Joint = RevoluteJoint | PrismaticJoint


@dataclass(frozen=True, slots=True)
class Link:
    """A rigid body carrying ``joints`` (names, in order: the first is its reference joint).

    Examples
    --------
    >>> ls.topology.Link("coupler", ["B", "C"])
    Link(name='coupler', joints=('B', 'C'))
    """

    name: str
    joints: tuple[str, ...]

    def __post_init__(self):
        _check_decl_name(self.name, "link")
        if isinstance(self.joints, str) or not isinstance(self.joints, Iterable):
            raise ModelError(f"link {self.name!r}: expected a list of joint names, got {self.joints!r}")
        joints = tuple(self.joints)
        for j in joints:
            if not isinstance(j, str):
                raise ModelError(f"link {self.name!r}: joint names are strings, got {j!r}")
        object.__setattr__(self, "joints", joints)


# =============================================================================
# mobility
# =============================================================================


def gruebler(n_links: int, j1: int, j2: int = 0) -> int:
    """Gruebler–Kutzbach mobility ``3 (n − 1) − 2 j1 − j2`` of a planar linkage.

    Examples
    --------
    >>> ls.topology.gruebler(4, 4), ls.topology.gruebler(6, 7), ls.topology.gruebler(3, 3)
    (1, 1, 0)
    """
    return 3 * (n_links - 1) - 2 * j1 - j2


@dataclass(frozen=True, slots=True)
class Mobility:
    """Mobility of a linkage: Gruebler's count and, when known, the Jacobian's opinion.

    ``rank`` is the rank of Φ_q (all joint variables) at an assembly pose and ``n_variables``
    the number of joint variables, so ``n_variables − rank`` is the instantaneous mobility
    there; it exceeds Gruebler's count for an over-constrained special geometry.

    Examples
    --------
    >>> m = ls.topology.Mobility(n_links=5, j1=6, rank=3, n_variables=4)
    >>> m.gruebler, m.rank_mobility, m.special
    (0, 1, True)
    """

    n_links: int
    j1: int
    j2: int = 0
    rank: int | None = None
    n_variables: int | None = None

    @property
    def gruebler(self) -> int:
        return gruebler(self.n_links, self.j1, self.j2)

    @property
    def loops(self) -> int:
        """Independent loops ``j − n + 1``."""
        return self.j1 + self.j2 - self.n_links + 1

    @property
    def rank_mobility(self) -> int | None:
        if self.rank is None or self.n_variables is None:
            return None
        return self.n_variables - self.rank

    @property
    def special(self) -> bool:
        """True when the Jacobian rank disagrees with Gruebler's count."""
        rm = self.rank_mobility
        return rm is not None and rm != self.gruebler

    def formula(self) -> str:
        """``M = 3(n − 1) − 2 j1 − j2`` with the numbers filled in."""
        s = f"M = 3({self.n_links} - 1) - 2*{self.j1}"
        if self.j2:
            s += f" - {self.j2}"
        return s + f" = {self.gruebler}"


def jacobian_rank(jac, *, rtol: float = 1e-8) -> int:
    """Numerical rank of a constraint Jacobian (columns normalized first, so mixed units are fine).

    Examples
    --------
    >>> ls.topology.jacobian_rank([[1.0, 2.0, 0.0], [2.0, 4.0, 0.0]])
    1
    """
    a = np.array(jac, dtype=float)
    if a.size == 0:
        return 0
    if not np.all(np.isfinite(a)):
        raise ModelError("the constraint Jacobian has infinite or NaN entries at the assembly pose "
                         "(coordinates or lengths too large for floating point?): use a larger length unit")
    big = np.max(np.abs(a), axis=0)  # scale by the largest entry first: the norms cannot overflow
    keep = big > 0
    if not keep.any():
        return 0
    a = a[:, keep] / big[keep]
    a = a / np.linalg.norm(a, axis=0)
    s = np.linalg.svd(a, compute_uv=False)
    return int(np.sum(s > rtol * s[0]))


def check_inputs(mobility: Mobility, n_inputs: int, *, where: str = "", inputs: Sequence[str] = ()) -> None:
    """Raise :class:`TopologyError` unless the declared inputs match the mobility.

    Also raises when the Jacobian rank at the assembly pose disagrees with Gruebler's count
    (an over-constrained special geometry such as a double parallelogram, or a drawing at a
    change point): such a case is reported, never silently accepted.

    Examples
    --------
    >>> ls.topology.check_inputs(ls.topology.Mobility(4, 4), 2)
    Traceback (most recent call last):
    ...
    loopsolve.errors.TopologyError: 2 input(s) declared but the Gruebler-Kutzbach mobility is 1 (M = 3(4 - 1) - 2*4 = 1): declare 1 input(s)
    """
    prefix = f"{where}: " if where else ""
    m = mobility.gruebler
    named = f" ({', '.join(inputs)})" if inputs else ""
    rank_note = ""
    if mobility.special:
        rank_note = (f"; at the assembly pose the Jacobian has rank {mobility.rank} for "
                     f"{mobility.n_variables} joint variables, which leaves {mobility.rank_mobility} "
                     "degree(s) of freedom: an over-constrained special geometry (such as a "
                     "parallelogram with a redundant link) or a drawing at a change point; remove "
                     "the redundant link or redraw the mechanism in a general position")
    if n_inputs != m:
        if m <= 0:
            what = "a structure" if m == 0 else "an over-constrained structure"
            advice = ("it cannot move: check the links and joints" if not rank_note else
                      "the loop equations would be redundant")
            raise TopologyError(f"{prefix}{n_inputs} input(s){named} declared but the Gruebler-Kutzbach "
                                f"mobility is {m} ({mobility.formula()}): {what}, {advice}{rank_note}")
        raise TopologyError(f"{prefix}{n_inputs} input(s){named} declared but the Gruebler-Kutzbach "
                            f"mobility is {m} ({mobility.formula()}): declare {m} input(s){rank_note}")
    if rank_note:
        raise TopologyError(f"{prefix}Gruebler-Kutzbach mobility {m} ({mobility.formula()}) "
                            f"disagrees with the Jacobian{rank_note}")


# =============================================================================
# the link–joint graph
# =============================================================================


def _lnode(name: str) -> tuple[str, str]:
    return ("link", name)


def _jnode(name: str) -> tuple[str, str]:
    return ("joint", name)


@dataclass(frozen=True)
class Topology:
    """Links and joints of a kinematic diagram, validated, with their graph.

    Every structural problem is collected and reported in one :class:`TopologyError`: a link
    naming an unknown joint, a prismatic joint naming an unknown guide link, a link with fewer
    than two joints, a joint that connects nothing, bodies not connected to the ground.

    Parameters
    ----------
    links : sequence of Link
        Must include the fixed link, named ``ground`` (:data:`GROUND`).
    joints : sequence of RevoluteJoint or PrismaticJoint
    where : str
        Prefix of error messages (the model file).

    Examples
    --------
    >>> T = ls.topology
    >>> top = T.Topology(
    ...     [T.Link("ground", ["O2", "O4"]), T.Link("crank", ["O2", "B"]),
    ...      T.Link("coupler", ["B", "C"]), T.Link("rocker", ["C", "O4"])],
    ...     [T.RevoluteJoint(n, xy) for n, xy in
    ...      dict(O2=(0, 0), B=(0, 25), C=(67.255, 44.411), O4=(60, 0)).items()])
    >>> top.mobility().gruebler, len(top.loops())
    (1, 1)
    >>> top.loops()[0]
    (('ground', 'O4', 'O2'), ('crank', 'O2', 'B'), ('coupler', 'B', 'C'), ('rocker', 'C', 'O4'))
    """

    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    where: str = field(default="", compare=False)

    def __post_init__(self):
        object.__setattr__(self, "links", tuple(self.links))
        object.__setattr__(self, "joints", tuple(self.joints))
        self._validate()

    # ------------------------------------------------------------------ lookups
    @cached_property
    def link_map(self) -> dict[str, Link]:
        return {lk.name: lk for lk in self.links}

    @cached_property
    def joint_map(self) -> dict[str, Joint]:
        return {j.name: j for j in self.joints}

    @cached_property
    def carriers(self) -> dict[str, tuple[str, ...]]:
        """Joint name → the links carrying it, in link order."""
        out: dict[str, list[str]] = {j.name: [] for j in self.joints}
        for lk in self.links:
            for j in lk.joints:
                if j in out and lk.name not in out[j]:
                    out[j].append(lk.name)
        return {k: tuple(v) for k, v in out.items()}

    @cached_property
    def graph(self) -> nx.Graph:
        """Bipartite graph: nodes ``("link", name)`` and ``("joint", name)``; edge = link carries joint."""
        import networkx as nx  # lazy: keeps `import loopsolve` light for the CLI

        g = nx.Graph()
        for lk in self.links:
            g.add_node(_lnode(lk.name), kind="link")
        for j in self.joints:
            g.add_node(_jnode(j.name), kind="joint", joint=j.kind)
        for lk in self.links:
            for j in lk.joints:
                if j in self.joint_map:
                    g.add_edge(_lnode(lk.name), _jnode(j))
        return g

    def _fail(self, problems: list[str]) -> None:
        prefix = f"{self.where}: " if self.where else ""
        if len(problems) == 1:
            raise TopologyError(prefix + problems[0], problems=[prefix + problems[0]])
        lines = [prefix + p for p in problems]
        raise TopologyError(f"{prefix}{len(problems)} topology problems:\n  " + "\n  ".join(problems),
                            problems=lines)

    def _validate(self) -> None:
        import networkx as nx  # lazy: keeps `import loopsolve` light for the CLI

        problems: list[str] = []
        for kind, items in (("link", self.links), ("joint", self.joints)):
            seen: set[str] = set()
            for it in items:
                if it.name in seen:
                    problems.append(f"the {kind} {it.name!r} is declared twice")
                seen.add(it.name)
        shared = sorted({lk.name for lk in self.links} & {j.name for j in self.joints})
        for n in shared:
            problems.append(f"{n!r} names both a link and a joint; give them different names")
        if GROUND not in {lk.name for lk in self.links}:
            problems.append(f"no link named {GROUND!r}: the fixed link (the frame) must be called "
                            f"{GROUND!r} and list the joints fixed to it")
        jnames = [j.name for j in self.joints]
        for lk in self.links:
            for j in lk.joints:
                if j not in self.joint_map:
                    problems.append(f"link {lk.name!r} names the unknown joint {j!r}; the joints are "
                                    + (", ".join(jnames) or "(none)"))
            dup = sorted({j for j in lk.joints if lk.joints.count(j) > 1})
            for j in dup:
                problems.append(f"link {lk.name!r} lists the joint {j!r} twice")
            if len(set(lk.joints)) < 2:
                have = ", ".join(lk.joints) if lk.joints else "none"
                problems.append(f"link {lk.name!r} carries {len(set(lk.joints))} joint(s) ({have}) but a link "
                                "needs at least two: list every joint it carries, or remove it")
        for j in self.joints:
            car = self.carriers[j.name]
            if not car:
                problems.append(f"joint {j.name!r} is not carried by any link: add it to the two links "
                                "it connects")
            elif len(car) == 1:
                problems.append(f"joint {j.name!r} is only on link {car[0]!r}: a joint connects two links; "
                                "add it to the other link's list")
            if isinstance(j, PrismaticJoint):
                if len(car) > 2:
                    problems.append(f"prismatic joint {j.name!r} is on {len(car)} links ({', '.join(car)}); "
                                    "a slider joins exactly two links")
                if j.guide is not None:
                    if j.guide not in self.link_map:
                        problems.append(f"prismatic joint {j.name!r} names the unknown link {j.guide!r} as "
                                        "its guide; the links are " + ", ".join(self.link_map))
                    elif j.guide not in car:
                        problems.append(f"prismatic joint {j.name!r} names {j.guide!r} as its guide, but "
                                        f"{j.guide!r} does not carry it (it joins {', '.join(car)})")
        if problems:
            self._fail(problems)
        g = self.graph
        if not nx.is_connected(g):
            comp = nx.node_connected_component(g, _lnode(GROUND))
            loose = [lk.name for lk in self.links if _lnode(lk.name) not in comp]
            self._fail([f"link(s) {', '.join(loose)} are not connected to the ground through joints: "
                        "a mechanism is one connected body chain; join them with a shared joint"])
        self._check_p_groups()

    def _check_p_groups(self) -> None:
        """A loop made only of prismatic joints (a wedge) is outside Gruebler's count: refuse it."""
        import networkx as nx  # lazy: keeps `import loopsolve` light for the CLI

        pg = nx.MultiGraph()
        pg.add_nodes_from(lk.name for lk in self.links)
        for j in self.joints:
            if isinstance(j, PrismaticJoint):
                a, b = self.carriers[j.name]
                pg.add_edge(a, b, key=j.name)
        for comp in nx.connected_components(pg):
            sub = pg.subgraph(comp)
            if sub.number_of_edges() >= len(comp):
                names = sorted(k for _, _, k in sub.edges(keys=True))
                self._fail([f"the prismatic joints {', '.join(names)} close a loop among themselves "
                            "(a wedge): its rotation is locked and Gruebler's count does not apply; "
                            "loopsolve needs at least one revolute joint in every loop"])

    # ------------------------------------------------------------------ structure
    def mobility(self, *, rank: int | None = None, n_variables: int | None = None) -> Mobility:
        """Gruebler–Kutzbach mobility (a joint on k links counts as k − 1 joints)."""
        j1 = 0
        for j in self.joints:
            j1 += len(self.carriers[j.name]) - 1
        return Mobility(len(self.links), j1, 0, rank, n_variables)

    def guide(self, joint: str) -> str:
        """The link along which prismatic ``joint`` slides (see :class:`PrismaticJoint`)."""
        j = self.joint_map[joint]
        if not isinstance(j, PrismaticJoint):
            raise ModelError(f"joint {joint!r} is not prismatic")
        if j.guide is not None:
            return j.guide
        a, b = self.carriers[joint]
        if GROUND in (a, b):
            return GROUND
        na, nb = len(self.link_map[a].joints), len(self.link_map[b].joints)
        return b if nb > na else a

    def slider(self, joint: str) -> str:
        """The link that slides along the guide of prismatic ``joint``."""
        g = self.guide(joint)
        a, b = self.carriers[joint]
        return b if a == g else a

    @cached_property
    def rotation_groups(self) -> dict[str, str]:
        """Link → representative of its rotation group (links joined by sliders turn together).

        The ground's group is represented by ``ground``; any other group by its link with the
        most joints (first in declaration order on a tie).
        """
        import networkx as nx  # lazy: keeps `import loopsolve` light for the CLI

        uf = nx.utils.UnionFind(lk.name for lk in self.links)
        for j in self.joints:
            if isinstance(j, PrismaticJoint):
                uf.union(*self.carriers[j.name])
        order = {lk.name: i for i, lk in enumerate(self.links)}
        groups: dict[str, list[str]] = {}
        for lk in self.links:
            groups.setdefault(uf[lk.name], []).append(lk.name)
        rep: dict[str, str] = {}
        for members in groups.values():
            if GROUND in members:
                r = GROUND
            else:
                r = max(members, key=lambda n: (len(self.link_map[n].joints), -order[n]))
            for mname in members:
                rep[mname] = r
        return rep

    def loops(self) -> tuple[tuple[tuple[str, str, str], ...], ...]:
        """Independent loops: a minimum cycle basis of the link–joint graph, in a fixed order.

        Each loop is a sequence of steps ``(link, joint_in, joint_out)``: walking the loop
        crosses ``link`` from ``joint_in`` to ``joint_out``. Loops start at the lowest link in
        declaration order (the ground when it is in the loop); shorter loops come first.
        """
        return self._loops

    @cached_property
    def _loops(self):
        import networkx as nx  # lazy: keeps `import loopsolve` light for the CLI

        g = self.graph
        rank = {_lnode(GROUND): -1}
        for i, lk in enumerate(self.links):
            rank.setdefault(_lnode(lk.name), i)
        for i, j in enumerate(self.joints):
            rank[_jnode(j.name)] = len(self.links) + i
        edges = {}
        for k, (u, v) in enumerate(sorted(g.edges(), key=lambda e: sorted((rank[e[0]], rank[e[1]])))):
            edges[frozenset((u, v))] = k
        n_needed = g.number_of_edges() - g.number_of_nodes() + 1
        if n_needed <= 0:
            return ()
        # Greedy GF(2) elimination over the cycles sorted by length gives a minimum cycle basis.
        # Only the shortest cycles are needed: enumerate those up to a length bound, and raise the
        # bound until the basis is complete (the same basis as enumerating every cycle, without the
        # exponential count of long cycles in a chain of many loops).
        bound = 8  # a four-bar: four links and four joints
        while True:
            cycles = []
            for count, cyc in enumerate(_short_cycles(g, rank, bound)):
                if count >= _MAX_CYCLES:
                    raise TopologyError(f"{self.where + ': ' if self.where else ''}the link-joint graph has more "
                                        f"than {_MAX_CYCLES} cycles of up to {bound // 2} links; split the model")
                cycles.append(_canonical_cycle(cyc, rank))
            cycles.sort(key=lambda c: (len(c), [rank[n] for n in c]))
            basis: list[tuple] = []
            pivots: dict[int, int] = {}  # GF(2) elimination: leading bit -> reduced row
            for cyc in cycles:
                bits = 0
                for a, b in zip(cyc, cyc[1:] + cyc[:1]):
                    bits ^= 1 << edges[frozenset((a, b))]
                while bits:
                    lead = bits.bit_length() - 1
                    if lead in pivots:
                        bits ^= pivots[lead]
                    else:
                        pivots[lead] = bits
                        basis.append(cyc)
                        break
                if len(basis) == n_needed:
                    break
            if len(basis) == n_needed or bound >= g.number_of_nodes():
                break
            bound += 2  # the link-joint graph is bipartite: every cycle has even length
        out = []
        for cyc in basis:
            steps = []
            n = len(cyc)
            for i, node in enumerate(cyc):
                if node[0] == "link":
                    steps.append((node[1], cyc[i - 1][1], cyc[(i + 1) % n][1]))
            out.append(tuple(steps))
        return tuple(out)


def _short_cycles(g, rank: Mapping, bound: int):
    """Every simple cycle of the undirected graph ``g`` with at most ``bound`` nodes, once each.

    A cycle is found from its lowest-ranked node, walking only through higher-ranked nodes,
    and kept in the direction whose second node ranks below its last (depth-first search with
    the path as a set; linear in the number of short paths, which stays small in a linkage
    whatever its number of loops).
    """
    adj = {u: sorted(g[u], key=rank.__getitem__) for u in g}
    for s in sorted(g, key=rank.__getitem__):
        rs = rank[s]
        path = [s]
        on_path = {s}
        stack = [iter(n for n in adj[s] if rank[n] > rs)]
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                stack.pop()
                on_path.discard(path.pop())
                continue
            if len(path) < bound:
                path.append(nxt)
                on_path.add(nxt)
                last = nxt
                # close the cycle through s (at least three nodes; each direction once)
                if len(path) >= 3 and s in g[last] and rank[path[1]] < rank[last]:
                    yield list(path)
                if len(path) < bound:
                    stack.append(iter(n for n in adj[last] if rank[n] > rs and n not in on_path))
                else:
                    on_path.discard(path.pop())


def _canonical_cycle(cyc: list, rank: Mapping) -> list:
    """Rotate a cycle to start at its lowest-ranked node, walking towards the lower neighbour."""
    i = min(range(len(cyc)), key=lambda k: rank[cyc[k]])
    c = cyc[i:] + cyc[:i]
    if len(c) > 2 and rank[c[-1]] < rank[c[1]]:
        c = [c[0]] + c[1:][::-1]
    return c
