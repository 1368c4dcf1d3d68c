"""Declaring a mechanism from Python: :class:`MechanismBuilder`, the model file's twin.

Each call adds one entry to a TOML-shaped specification; :meth:`MechanismBuilder.build` hands it
to :func:`loopsolve.model.spec.build_mechanism`, so a builder and a model file with the same content
give the same :class:`loopsolve.model.mechanism.Mechanism` and the same derivation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..errors import ModelError
from .mechanism import Mechanism
from .diagram import diagram_to_spec
from .spec import build_mechanism

__all__ = ["MechanismBuilder"]


def _plain(value):
    """A builder argument as the TOML reader gives it: tuples as lists, mappings as dicts, all the way down."""
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


class MechanismBuilder:
    """Declare a mechanism from Python; :meth:`~MechanismBuilder.build` gives the same :class:`Mechanism` as a file.

    Parameters
    ----------
    name : str, optional
        The mechanism's name (default ``"mechanism"``).
    length_unit : str, optional
        Unit of every length of the declaration (default ``"mm"``).
    angle_unit : str, optional
        ``"deg"`` (default) or ``"rad"``: unit of the angles of the declaration.

    Examples
    --------
    >>> b = ls.MechanismBuilder("Four-bar", length_unit="mm", angle_unit="deg")
    >>> for n, v in dict(r1=60, r2=25, r3=70, r4=45).items():
    ...     b = b.parameter(n, v)
    >>> b = b.variable("theta2", input=True, guess=90).variable("theta3", guess=20)
    >>> b = b.variable("theta4", guess=80)
    >>> b = b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
    >>> b = b.vector("r3", length="r3", angle="theta3").vector("r4", length="r4", angle="theta4")
    >>> mech = b.loop("r2 + r3 = r1 + r4").point("C", "r2 + r3").build()
    >>> round(mech.solve(90)["theta4"], 2)
    80.72
    """

    def __init__(self, name: str = "mechanism", *, length_unit: str = "mm", angle_unit: str = "deg"):
        self._spec: dict[str, Any] = {
            "name": name,
            "units": {"length": length_unit, "angle": angle_unit},
            "parameters": {},
            "variables": {},
            "vectors": {},
            "loops": [],
            "points": {},
        }

    def _put(self, section: str, name: str, value: Any) -> "MechanismBuilder":
        if name in self._spec[section]:
            raise ModelError(f"{section}.{name}: {name!r} is declared twice")
        self._spec[section][name] = value
        return self

    def parameter(self, name: str, value: float | str) -> "MechanismBuilder":
        """Add a named constant (a number in model units, or a quantity string like ``"30deg"``)."""
        return self._put("parameters", name, value)

    def variable(self, name: str, *, input: bool = False, guess=None, speed=None, accel=None,
                 jerk=None, kind: str | None = None) -> "MechanismBuilder":
        """Add a joint variable; ``guess`` (model units) picks the assembly mode."""
        d: dict[str, Any] = {}
        for k, v in (("input", input if input else None), ("guess", guess), ("speed", speed),
                     ("accel", accel), ("jerk", jerk), ("kind", kind)):
            if v is not None:
                d[k] = v
        return self._put("variables", name, d)

    def vector(self, name: str, *, length=None, angle=None, offset=None, x=None, y=None) -> "MechanismBuilder":
        """Add a vector: polar (``length``, ``angle`` [, ``offset``]) or Cartesian (``x``, ``y``)."""
        d = {k: v for k, v in (("length", length), ("angle", angle), ("offset", offset), ("x", x), ("y", y))
             if v is not None}
        return self._put("vectors", name, d)

    def loop(self, equation: str, *, name: str | None = None) -> "MechanismBuilder":
        """Add a vector loop such as ``"r2 + r3 = r1 + r4"``."""
        d: dict[str, Any] = {"equation": equation}
        if name is not None:
            d["name"] = name
        self._spec["loops"].append(d)
        return self

    def mode(self, alias: str, signature: str) -> "MechanismBuilder":
        """Name an assembly mode (e.g. ``mode("open", "-")``)."""
        self._spec.setdefault("modes", {})[alias] = signature
        return self

    def point(self, name: str, terms: str) -> "MechanismBuilder":
        """Add a point of interest: a sum of vectors with optional factors (``"r2 + 0.5*r3"``), or ``"0"``."""
        return self._put("points", name, terms)

    def body(self, name: str, *, com, mass=None, inertia=None, angle=None, joints=(), guide=None,
             guide_body=None, bar=None) -> "MechanismBuilder":
        """Add a moving rigid body (see :mod:`loopsolve.model.bodies`; SI numbers or quantity strings)."""
        d: dict[str, Any] = {"com": com}
        for k, v in (("mass", mass), ("inertia", inertia), ("angle", angle), ("guide", guide),
                     ("guide_body", guide_body), ("bar", bar)):
            if v is not None:
                d[k] = dict(v) if isinstance(v, Mapping) else v
        if joints:
            d["joints"] = list(joints)
        table = self._spec.setdefault("bodies", {})
        if name in table:
            raise ModelError(f"bodies.{name}: {name!r} is declared twice")
        table[name] = d
        return self

    def load(self, **entry) -> "MechanismBuilder":
        """Add a ``[[loads]]`` entry: ``load(at="C", body="rocker", force=["-50N", 0])``, ``load(body=..., torque=...)``,
        ``load(spring=["A", "B"], stiffness=..., free_length=...)``, ``load(damper=[...], damping=...)``."""
        self._spec.setdefault("loads", []).append({k: list(v) if isinstance(v, tuple) else v for k, v in entry.items()})
        return self

    # ---- higher pairs and friction (the model file's [constraints], [gears], [cams], [slots], [rolling],
    # [friction]; the keys of each entry as in docs/reference/model_file.md)
    def constraint(self, name: str, equation: str) -> "MechanismBuilder":
        """Add a scalar constraint (``[constraints]``): ``constraint("mark", "phi = theta")``.

        Parameters
        ----------
        name : str
            The constraint's name (its row of Φ is ``constraints.<name>``).
        equation : str
            An equation of the variables and parameters in the model file's expression language.
        """
        return self._put_table("constraints", name, equation)

    def gear(self, name: str, **entry) -> "MechanismBuilder":
        """Add a gear pair (``[gears]``): ``gear("g1", a="theta_s", b="theta_p", carrier="theta2", za=24, zb=36)``.

        Parameters
        ----------
        name : str
            The pair's name.
        **entry
            The keys of a ``[gears]`` entry (tooth numbers or pitch radii, the two links, the carrier, the
            kind), as in the model file.
        """
        return self._put_table("gears", name, entry)

    def cam(self, name: str, **entry) -> "MechanismBuilder":
        """Add a disk cam and its follower (``[cams.NAME]``): ``cam("c1", cam="theta2", follower="s", ...)``.

        Parameters
        ----------
        name : str
            The cam's name.
        **entry
            The keys of a ``[cams.NAME]`` table (``law`` segments as a list of tables, or ``profile``).
        """
        return self._put_table("cams", name, entry)

    def slot(self, name: str, **entry) -> "MechanismBuilder":
        """Add a pin in a straight or circular slot of a moving link (``[slots]``).

        Parameters
        ----------
        name : str
            The slot's name.
        **entry
            The keys of a ``[slots]`` entry, as in the model file.
        """
        return self._put_table("slots", name, entry)

    def rolling(self, name: str, **entry) -> "MechanismBuilder":
        """Add a circle rolling without slipping on a line or a circle (``[rolling]``).

        Parameters
        ----------
        name : str
            The contact's name.
        **entry
            The keys of a ``[rolling]`` entry, as in the model file.
        """
        return self._put_table("rolling", name, entry)

    def friction(self, joint: str, *, mu, radius=None) -> "MechanismBuilder":
        """Add Coulomb friction at a joint (``[friction]``): ``friction("O2", mu=0.1, radius="6mm")``.

        Parameters
        ----------
        joint : str
            A pin of the bodies (then ``radius``, its journal radius, is needed), a guided body, a slot or a
            knife-edge or flat-face cam.
        mu : float
            The coefficient of friction.
        radius : float or str, optional
            The journal radius of a revolute joint.
        """
        return self._put_table("friction", joint, {"mu": mu} | ({} if radius is None else {"radius": radius}))

    def _put_table(self, section: str, name: str, value: Any) -> "MechanismBuilder":
        table = self._spec.setdefault(section, {})
        if name in table:
            raise ModelError(f"{section}.{name}: {name!r} is declared twice")
        table[name] = _plain(value)
        return self

    def gravity(self, gx=0.0, gy="-9.81m/s^2") -> "MechanismBuilder":
        """Set the gravity vector (components in m/s² or with a unit)."""
        self._spec["gravity"] = [gx, gy]
        return self

    # ------------------------------------------------------- kinematic diagram
    def revolute(self, name: str, at) -> "MechanismBuilder":
        """Add a pin joint drawn at ``at`` = (x, y) (kinematic-diagram models)."""
        return self._put_diagram("joints", name, {"at": list(at)})

    def prismatic(self, name: str, at, axis, *, guide: str | None = None) -> "MechanismBuilder":
        """Add a slider joint drawn at ``at``, sliding along ``axis`` ((dx, dy) or an angle)."""
        d: dict[str, Any] = {"at": list(at), "type": "P",
                             "axis": list(axis) if isinstance(axis, (list, tuple)) else axis}
        if guide is not None:
            d["guide"] = guide
        return self._put_diagram("joints", name, d)

    def link(self, name: str, joints: Sequence[str]) -> "MechanismBuilder":
        """Add a link carrying ``joints`` (the fixed link is ``"ground"``)."""
        return self._put_diagram("links", name, list(joints))

    def drive(self, *, joint: str | Sequence[str] | None = None, link: str | Sequence[str] | None = None,
              speed=None, accel=None, jerk=None) -> "MechanismBuilder":
        """Name the driven joint(s) or link(s) of a kinematic diagram (and the first one's rates).

        Examples
        --------
        >>> b = ls.MechanismBuilder("Four-bar (diagram)")
        >>> for n, xy in dict(O2=(0, 0), B=(0, 25), C=(67.255, 44.411), O4=(60, 0)).items():
        ...     b = b.revolute(n, xy)
        >>> b = b.link("ground", ["O2", "O4"]).link("crank", ["O2", "B"])
        >>> b = b.link("coupler", ["B", "C"]).link("rocker", ["O4", "C"]).drive(joint="O2")
        >>> round(b.build().solve(90)["theta_rocker"], 2)
        80.72
        """
        d: dict[str, Any] = {}
        for k, v in (("joint", joint), ("link", link), ("speed", speed), ("accel", accel), ("jerk", jerk)):
            if v is not None:
                d[k] = v if isinstance(v, (str, int, float)) else list(v)
        self._spec["input"] = d
        return self

    def _put_diagram(self, section: str, name: str, value: Any) -> "MechanismBuilder":
        table = self._spec.setdefault(section, {})
        if name in table:
            raise ModelError(f"{section}.{name}: {name!r} is declared twice")
        table[name] = value
        return self

    def build(self) -> Mechanism:
        """Validate and return the :class:`Mechanism` (all problems reported at once)."""
        if self._spec.get("joints") or self._spec.get("links"):
            busy = [k for k in ("variables", "vectors", "loops", "points") if self._spec.get(k)]
            if busy:
                raise ModelError("a mechanism is declared either by joints and links (a kinematic diagram) "
                                 f"or by variables, vectors and loops, not both (this one also has {', '.join(busy)})")
            data = {k: v for k, v in self._spec.items() if k not in ("variables", "vectors", "loops", "points")}
            return build_mechanism(diagram_to_spec(data, source=None), source=None)
        return build_mechanism(self._spec, source=None)
