"""Links, joints and the two structure graphs: mobility, loops, errors, solve order."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.model import diagram
from loopsolve.errors import ModelError, TopologyError
from loopsolve.model.topology import (Block, Link, Mobility, PrismaticJoint, RevoluteJoint, Topology, check_inputs,
                                gruebler, jacobian_rank, solve_order)

MODELS = ls.models_dir()
DIAGRAM_MODELS = ["thesis_crank_rocker_diagram", "watt2_sixbar", "stephenson3_sixbar", "whitworth_quick_return",
                  "crank_shaper", "fivebar_two_inputs"]


def R(name, x, y):
    return RevoluteJoint(name, (x, y))


def chain(links: dict, joints: dict) -> Topology:
    """Topology from {link: [joints]} and {joint: (x, y) or (x, y, axis)}."""
    js = []
    for n, v in joints.items():
        js.append(PrismaticJoint(n, v[:2], v[2]) if len(v) == 3 else RevoluteJoint(n, v))
    return Topology([Link(n, j) for n, j in links.items()], js)


FOURBAR = dict(links={"ground": ["O2", "O4"], "crank": ["O2", "B"], "coupler": ["B", "C"], "rocker": ["O4", "C"]},
               joints={"O2": (0, 0), "B": (0, 25), "C": (67.255, 44.411), "O4": (60, 0)})
SLIDER_CRANK = dict(links={"ground": ["O2", "S"], "crank": ["O2", "B"], "rod": ["B", "C"], "slider": ["C", "S"]},
                    joints={"O2": (0, 0), "B": (20, 30), "C": (80, 10), "S": (80, 10, (1, 0))})
FIVEBAR = dict(links={"ground": ["O1", "O5"], "a": ["O1", "A"], "b": ["A", "P"], "c": ["P", "B"], "d": ["O5", "B"]},
               joints={"O1": (0, 0), "O5": (40, 0), "A": (0, 20), "B": (40, 20), "P": (20, 65)})
TRIANGLE = dict(links={"ground": ["A", "B"], "a": ["A", "C"], "b": ["B", "C"]},
                joints={"A": (0, 0), "B": (10, 0), "C": (5, 8)})
# Watt: ternary ground and ternary rocker joined at O4; Stephenson: ternary ground and coupler apart
WATT = dict(links={"ground": ["O2", "O4", "O6"], "crank": ["O2", "A"], "coupler": ["A", "B"],
                   "rocker": ["O4", "B", "C"], "c2": ["C", "D"], "out": ["O6", "D"]},
            joints={"O2": (0, 0), "A": (1, 2), "B": (6, 3), "O4": (6, 0), "C": (4, -1), "D": (7, 4), "O6": (10, 5)})
STEPHENSON = dict(links={"ground": ["O2", "O4", "O6"], "crank": ["O2", "A"], "coupler": ["A", "B", "C"],
                         "rocker": ["O4", "B"], "l5": ["C", "D"], "l6": ["O6", "D"]},
                  joints={"O2": (0, 0), "A": (1, 2), "B": (6, 3), "O4": (6, 0), "C": (4, 5), "D": (1, 6),
                          "O6": (2, 9)})
# a parallelogram four-bar with a redundant third crank: Gruebler 0, yet it moves
DOUBLE_PARALLELOGRAM = dict(
    links={"ground": ["O1", "O2", "O3"], "a": ["O1", "A"], "b": ["O2", "B"], "c": ["O3", "C"],
           "coupler": ["A", "B", "C"]},
    joints={"O1": (0, 0), "O2": (20, 0), "O3": (40, 0), "A": (6, 8), "B": (26, 8), "C": (46, 8)})


class TestMobility:
    @pytest.mark.parametrize("case, expected", [
        (FOURBAR, 1), (SLIDER_CRANK, 1), (FIVEBAR, 2), (WATT, 1), (STEPHENSON, 1), (TRIANGLE, 0),
        (DOUBLE_PARALLELOGRAM, 0),
    ], ids=["fourbar", "slider-crank", "fivebar", "watt", "stephenson", "triangle", "double-parallelogram"])
    def test_gruebler_of_classic_chains(self, case, expected):
        top = chain(**case)
        m = top.mobility()
        assert m.gruebler == expected
        # independent loops = joints - links + 1, and the cycle basis has that many loops
        assert m.loops == len(top.joints) - len(top.links) + 1 == len(top.loops())

    def test_gruebler_formula_and_counts(self):
        assert gruebler(4, 4) == 1
        assert gruebler(6, 7) == 1
        assert gruebler(5, 5) == 2
        assert gruebler(3, 3) == 0
        assert gruebler(4, 3, 1) == 2  # a half joint removes one freedom
        m = chain(**SLIDER_CRANK).mobility()
        assert (m.n_links, m.j1, m.j2) == (4, 4, 0)
        assert m.formula() == "M = 3(4 - 1) - 2*4 = 1"

    def test_compound_joint_counts_links_minus_one(self):
        # three links meeting at one pin C: it counts as two joints (an over-constrained structure)
        top = chain(links={"ground": ["A", "B", "E"], "a": ["A", "C"], "b": ["B", "C"], "e": ["E", "C"]},
                    joints={"A": (0, 0), "B": (10, 0), "E": (5, -5), "C": (5, 8)})
        m = top.mobility()
        assert m.j1 == 5 and m.gruebler == -1 and m.loops == 2  # 3 pins + C as two

    @pytest.mark.parametrize("model, expected", [
        ("thesis_crank_rocker_diagram", 1), ("watt2_sixbar", 1), ("stephenson3_sixbar", 1),
        ("whitworth_quick_return", 1), ("crank_shaper", 1), ("fivebar_two_inputs", 2),
    ])
    def test_shipped_diagrams_mobility_and_rank(self, model, expected):
        mech = ls.load(MODELS / f"{model}.toml")
        top = diagram.topology_of(mech)
        assert top.mobility().gruebler == expected
        d = mech.info()
        assert d["mobility"] == expected
        assert d["mobility_rank"] == expected  # second opinion: the nullity of Φ_q at the drawn pose
        assert len(d["inputs"]) == expected
        assert len(mech.loops) == top.mobility().loops

    def test_vector_models_mobility(self):
        for name in ("thesis_crank_rocker", "example1_slider_crank", "quick_return"):
            d = ls.load(MODELS / f"{name}.toml").info()
            assert d["mobility"] == 1 and d["mobility_rank"] == 1
            assert "topology" not in d

    def test_double_parallelogram_rank_disagrees(self):
        top = chain(**DOUBLE_PARALLELOGRAM)
        data = _data(DOUBLE_PARALLELOGRAM, input={"joint": "O1"})
        with pytest.raises(TopologyError) as exc:
            diagram.diagram_to_spec(data)
        msg = str(exc.value)
        assert "1 input(s) (O1) declared" in msg and "mobility is 0" in msg
        assert "rank 3" in msg and "leaves 1 degree(s) of freedom" in msg and "over-constrained" in msg
        assert top.mobility().gruebler == 0

    def test_mobility_object(self):
        m = Mobility(5, 6, rank=3, n_variables=4)
        assert (m.gruebler, m.rank_mobility, m.special) == (0, 1, True)
        assert not Mobility(4, 4, rank=2, n_variables=3).special
        assert Mobility(4, 4).rank_mobility is None

    def test_jacobian_rank_normalizes_columns(self):
        # a length column (scale 1e3) next to a slide column (scale 1): still full rank
        assert jacobian_rank([[1e3, 0.0], [0.0, 1.0]]) == 2
        assert jacobian_rank([[1e3, 1.0], [2e3, 2.0]]) == 1
        assert jacobian_rank(np.zeros((2, 3))) == 0

    def test_check_inputs_names_both_counts(self):
        with pytest.raises(TopologyError, match=r"2 input\(s\) \(O2, O4\) declared but the Gruebler-Kutzbach "
                                                r"mobility is 1 \(M = 3\(4 - 1\) - 2\*4 = 1\): declare 1"):
            check_inputs(Mobility(4, 4), 2, inputs=["O2", "O4"])
        check_inputs(Mobility(4, 4), 1)  # agrees: no error
        with pytest.raises(TopologyError, match="disagrees with the Jacobian"):
            check_inputs(Mobility(4, 4, rank=1, n_variables=3), 1)


def _data(case, *, input=None, extra_joints=None):
    joints = {}
    for n, v in case["joints"].items():
        if isinstance(v, dict):
            joints[n] = dict(v)
            continue
        joints[n] = {"at": list(v[:2])}
        if len(v) == 3:
            joints[n].update(type="P", axis=list(v[2]))
    joints.update(extra_joints or {})
    d = {"name": "t", "joints": joints, "links": {k: list(v) for k, v in case["links"].items()}}
    if input is not None:
        d["input"] = input
    return d


def _modify(case, links=None, joints=None, drop_links=(), drop_joints=()):
    lk = {k: list(v) for k, v in case["links"].items() if k not in drop_links}
    lk.update(links or {})
    js = {k: v for k, v in case["joints"].items() if k not in drop_joints}
    js.update(joints or {})
    return {"links": lk, "joints": js}


BROKEN = [
    ("unknown joint", _modify(FOURBAR, links={"coupler": ["B", "X"]}), {"joint": "O2"},
     "link 'coupler' names the unknown joint 'X'; the joints are O2, B, C, O4"),
    ("joint on one link", _modify(FOURBAR, links={"rocker": ["O4", "E"]}, joints={"E": (60, 40)}), {"joint": "O2"},
     "joint 'C' is only on link 'coupler': a joint connects two links"),
    ("joint on no link", _modify(FOURBAR, joints={"E": (9, 9)}), {"joint": "O2"},
     "joint 'E' is not carried by any link"),
    ("link with one joint", _modify(FOURBAR, links={"arm": ["C"]}), {"joint": "O2"},
     "link 'arm' carries 1 joint(s) (C) but a link needs at least two"),
    ("disconnected bodies", _modify(FOURBAR, links={"p": ["X", "Y"], "q": ["X", "Y"]},
                                    joints={"X": (100, 100), "Y": (120, 100)}), {"joint": "O2"},
     "link(s) p, q are not connected to the ground through joints"),
    ("no ground", {"links": {"frame" if k == "ground" else k: v for k, v in FOURBAR["links"].items()},
                   "joints": FOURBAR["joints"]}, {"joint": "O2"},
     "no link named 'ground'"),
    ("joint naming an unknown link",
     _modify(SLIDER_CRANK, joints={"S": {"at": [80, 10], "type": "P", "axis": [1, 0], "guide": "frame"}}),
     {"joint": "O2"},
     "prismatic joint 'S' names the unknown link 'frame' as its guide"),
    ("slider on three links", _modify(SLIDER_CRANK, links={"extra": ["S", "B"]}), {"joint": "O2"},
     "prismatic joint 'S' is on 3 links (ground, slider, extra); a slider joins exactly two links"),
    ("link and joint share a name", _modify(FOURBAR, links={"B": ["B", "C"]}, drop_links=("coupler",)),
     {"joint": "O2"}, "'B' names both a link and a joint"),
    ("too many inputs", FOURBAR, {"joint": ["O2", "O4"]},
     "2 input(s) (O2, O4) declared but the Gruebler-Kutzbach mobility is 1 (M = 3(4 - 1) - 2*4 = 1): declare 1 input(s)"),
    ("too few inputs", FIVEBAR, {"joint": "O1"},
     "1 input(s) (O1) declared but the Gruebler-Kutzbach mobility is 2 (M = 3(5 - 1) - 2*5 = 2): declare 2 input(s)"),
    ("driving a structure", TRIANGLE, {"joint": "A"},
     "1 input(s) (A) declared but the Gruebler-Kutzbach mobility is 0 (M = 3(3 - 1) - 2*3 = 0): a structure"),
    ("no input", FOURBAR, None, "no [input]: the mobility is 1 (M = 3(4 - 1) - 2*4 = 1); name the driven joint"),
    ("structure without input", TRIANGLE, None, "mobility 0 (M = 3(3 - 1) - 2*3 = 0): a structure has no motion"),
    ("unknown input link", FOURBAR, {"link": "lever"}, "input.link: the input names the unknown link 'lever'"),
    ("unknown input joint", FOURBAR, {"joint": "Q"}, "input.joint: the input names the unknown joint 'Q'"),
    ("driving a floating joint", FOURBAR, {"joint": "B"},
     "the driven joint 'B' joins the moving links crank, coupler"),
    ("driving the ground", FOURBAR, {"link": "ground"}, "link 'ground' does not turn"),
    ("pins drawn together", _modify(FOURBAR, joints={"C": (0, 25)}), {"joint": "O2"},
     "joints 'B' and 'C' of link 'coupler' are drawn at the same point"),
    ("flat parallelogram", {"links": FOURBAR["links"],
                            "joints": {"O2": (0, 0), "B": (25, 0), "C": (85, 0), "O4": (60, 0)}},
     {"joint": "O2"}, "disagrees with the Jacobian"),
    ("wedge of sliders", {"links": {"ground": ["P1", "P3", "O"], "a": ["P1", "P2", "A"], "b": ["P2", "P3"],
                                    "c": ["O", "A"]},
                          "joints": {"P1": (0, 0, (1, 0)), "P2": (1, 1, (0, 1)), "P3": (2, 0, (1, 1)),
                                     "O": (5, 5), "A": (6, 6)}},
     {"joint": "O"}, "close a loop among themselves"),
]


class TestBrokenTopologies:
    @pytest.mark.parametrize("case, inp, message", [b[1:] for b in BROKEN], ids=[b[0] for b in BROKEN])
    def test_error_table(self, case, inp, message):
        data = _data(case, input=inp)
        with pytest.raises(TopologyError) as exc:
            diagram.diagram_to_spec(data, source="broken.toml")
        assert message in str(exc.value)
        assert str(exc.value).startswith("broken.toml")
        assert isinstance(exc.value, ModelError) and isinstance(exc.value, ValueError)

    def test_all_problems_at_once(self):
        case = _modify(FOURBAR, links={"coupler": ["B", "X"], "arm": ["C"]})
        with pytest.raises(TopologyError) as exc:
            Topology([Link(n, j) for n, j in case["links"].items()],
                     [RevoluteJoint(n, v) for n, v in case["joints"].items()])
        assert len(exc.value.problems) >= 2
        assert "unknown joint 'X'" in str(exc.value) and "link 'arm' carries 1 joint(s)" in str(exc.value)

    @pytest.mark.parametrize("make, message", [
        (lambda: RevoluteJoint("B", (0, "x")), "expected two numbers"),
        (lambda: RevoluteJoint("B", (0, math.inf)), "not a pair of finite numbers"),
        (lambda: PrismaticJoint("S", (0, 0), (0, 0)), "slide axis (0, 0) has zero length"),
        (lambda: RevoluteJoint("2B", (0, 0)), "a name is letters"),
        (lambda: RevoluteJoint("B__1", (0, 0)), "a name is letters"),
        (lambda: Link("crank", "O2"), "expected a list of joint names"),
    ])
    def test_declaration_errors(self, make, message):
        with pytest.raises(ModelError, match=message.replace("(", r"\(").replace(")", r"\)")):
            make()


class TestLoopsAndGroups:
    def test_loops_are_shortest_and_ordered(self):
        top = chain(**STEPHENSON)
        loops = top.loops()
        assert [len(lp) for lp in loops] == [4, 5]
        assert loops[0] == (("ground", "O4", "O2"), ("crank", "O2", "A"), ("coupler", "A", "B"),
                            ("rocker", "B", "O4"))
        for lp in loops:  # every step leaves a link through the joint the next step enters by
            for (l1, _, out), (l2, inn, _) in zip(lp, lp[1:] + lp[:1]):
                assert out == inn and l1 != l2

    def test_loops_do_not_depend_on_hash_seed(self, tmp_path):
        import subprocess
        import sys

        code = ("import loopsolve as ls; from loopsolve import diagram as d; "
                "m = ls.load(ls.models_dir() / 'stephenson3_sixbar.toml'); "
                "print([l.text for l in m.loops])")
        outs = set()
        for seed in ("1", "2", "3"):
            env = {"PYTHONHASHSEED": seed, "LOOPSOLVE_CACHE_DIR": str(tmp_path), "PATH": "/usr/bin:/bin"}
            outs.add(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                                    check=True).stdout)
        assert len(outs) == 1

    def test_rotation_groups_and_guides(self):
        top = diagram.topology_of(ls.load(MODELS / "whitworth_quick_return.toml"))
        groups = top.rotation_groups
        assert groups["block"] == groups["lever"] == "lever"  # a slider turns with its guide
        assert groups["ram"] == "ground"
        assert top.guide("slot") == "lever" and top.slider("slot") == "block"
        assert top.guide("way") == "ground" and top.slider("way") == "ram"


class TestSolveOrder:
    @pytest.mark.parametrize("model", ["watt2_sixbar", "stephenson3_sixbar"])
    def test_sixbar_is_two_2x2_blocks(self, model):
        ck = ls.load(MODELS / f"{model}.toml").compile()
        assert [(len(b.eqs), len(b.unknowns)) for b in ck.blocks] == [(2, 2), (2, 2)]
        first = [ck.unknowns[j] for j in ck.blocks[0].unknowns]
        assert first == ["theta_coupler", "theta_rocker"]
        assert ck.blocks[0].eqs == (0, 1) and ck.blocks[1].eqs == (2, 3)

    def test_quick_return_blocks(self):
        ck = ls.load(MODELS / "whitworth_quick_return.toml").compile()
        names = [[ck.unknowns[j] for j in b.unknowns] for b in ck.blocks]
        assert names == [["theta_lever", "s_slot"], ["theta_rod"], ["s_way"]]

    def test_solve_order_of_a_permuted_watt_incidence(self):
        # unknowns (t5, t6, t3, t4) and equations of loop 2 first: the order is still loop 1, loop 2
        inc = [[1, 1, 0, 1], [1, 1, 0, 1], [0, 0, 1, 1], [0, 0, 1, 1]]
        blocks = solve_order(inc)
        assert blocks == (Block((2, 3), (2, 3)), Block((0, 1), (0, 1)))

    def test_structurally_singular_system(self):
        with pytest.raises(TopologyError, match="cannot determine the unknown"):
            solve_order([[1, 0], [1, 0]], unknown_names=["a", "b"])
        with pytest.raises(TopologyError, match="not square"):
            solve_order([[1, 1]])

    @pytest.mark.parametrize("model", ["watt2_sixbar", "stephenson3_sixbar", "whitworth_quick_return",
                                       "crank_shaper"])
    def test_blocks_equal_full_newton(self, model):
        """Newton block by block gives the same root as a plain Newton on the whole system."""
        from loopsolve.kinematics.solve import initial_z, solve_position

        mech = ls.load(MODELS / f"{model}.toml")
        ck = mech.compile()
        sw = mech.sweep(0, 360, 30, speed=1)
        assert len(sw) == 13 and not sw.events
        rng = np.random.default_rng(5)
        u = ck.unknown_idx
        for st in sw.states:
            z0 = st.z.copy()
            z0[u] += rng.normal(scale=0.02, size=len(u)) * np.where(
                [ck.kinds[i] is ls.units.Kind.ANGLE for i in u], 1.0, ck.scale)
            z_blocks, _, _ = solve_position(ck, z0)
            z = z0.copy()
            for _ in range(50):  # plain Newton on all of Φ at once
                step = np.linalg.solve(ck.jac(z), -ck.phi(z))
                z[u] += step
                if np.linalg.norm(step) < 1e-13 * ck.scale:
                    break
            assert np.abs(ck.phi(z)).max() < 1e-9
            np.testing.assert_allclose(z_blocks, z, atol=1e-9)
            np.testing.assert_allclose(z_blocks, st.z, atol=1e-9)
        assert initial_z(ck).shape == (len(ck.variables),)

    def test_signature_is_per_block(self):
        mech = ls.load(MODELS / "watt2_sixbar.toml")
        sw = mech.sweep(0, 360, 10)
        sigs = {st.mode for st in sw.states}
        assert len(sigs) == 1 and len(next(iter(sigs))) == 2  # one sign per block, kept over the turn


def test_design_example_is_shipped():
    """The shipped diagram model is the kinematic-diagram example of the design notes."""
    data = tomllib.loads((MODELS / "thesis_crank_rocker_diagram.toml").read_text())
    assert data["joints"] == {"O2": {"at": [0, 0]}, "B": {"at": [0, 25]}, "C": {"at": [67.255, 44.411]},
                              "O4": {"at": [60, 0]}}
    assert data["links"] == {"ground": ["O2", "O4"], "crank": ["O2", "B"], "coupler": ["B", "C"],
                             "rocker": ["C", "O4"]}
    assert data["input"] == {"joint": "O2"}
    assert data["units"] == {"length": "mm", "angle": "deg"}
