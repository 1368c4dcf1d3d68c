"""``[gears]``: spur gear pairs (external, internal) and rack-and-pinion, relative to a carrier.

A pair ties the angles of two gears relative to the carrier that holds their axes (the frame by
default) by Willis' formula::

    θ_mate − θ_c = −(N_gear / N_mate)(θ_gear − θ_c) + phase     (external; + for internal)
    x = radius·(θ_gear − θ_c) + phase                           (rack: the rack's travel x)

with the ratio from tooth numbers (``teeth = [24, 36]``, integers or integer parameters) or pitch
radii (``radii = ["r_s", "r_p"]``); ``module`` with ``teeth`` gives the radii (m·N/2). ``phase`` (the
model's angle unit; length unit for a rack) defaults to what the guesses give, so the pair meshes at
the guessed pose. ``gear``/``mate``/``carrier`` name angle variables or ``"frame"`` (a gear fixed to
the frame: the ring of a planetary stage held still). ``pressure_angle`` (default 20°) sets the line
of action of the tooth force; ``centers = ["O2", "P"]`` names the gears' centres as points (otherwise
each centre is found as the pivot of the gear's link on the carrier: their relative instant centre).

Checks here: integer teeth, positive radii, teeth and radii that agree, distinct members. Along the
motion (:mod:`loopsolve.kinematics.pairchecks`): the centre distance stays the sum (the difference,
internal) of the pitch radii.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from . import expr as _expr
from .units import Kind

__all__ = ["GearPair", "parse", "kind_hints", "names_used", "teeth_parameters", "ratio_values"]

_KEYS = {"gear", "mate", "rack", "carrier", "teeth", "radii", "radius", "module", "internal", "phase",
         "pressure_angle", "centers"}
_EXAMPLE = '{ gear = "theta2", mate = "theta5", teeth = [24, 36] }'


@dataclass(frozen=True, slots=True)
class GearPair:
    """One gear pair (``kind`` ``"external"``, ``"internal"`` or ``"rack"``).

    ``gear``, ``mate`` and ``carrier`` are variable names, ``""`` for the frame (for a rack, ``mate`` is
    the rack's travel). ``teeth``/``radii`` are parsed expressions (``None`` when not given; one entry
    for a rack's pinion), ``module`` likewise. ``phase`` is the explicit phase (model units) or
    ``None``; then ``ref`` holds the guesses of gear, mate and carrier (internal units) it comes from.
    ``pressure_angle`` is in radians.
    """

    name: str
    key: str
    kind: str
    gear: str
    mate: str
    carrier: str
    teeth: tuple | None
    radii: tuple | None
    module: object
    phase: object
    ref: tuple
    pressure_angle: float
    centers: tuple
    text: str

    @property
    def internal(self) -> bool:
        return self.kind == "internal"

    @property
    def rack(self) -> bool:
        return self.kind == "rack"

    @property
    def members(self) -> tuple[str, ...]:
        """The variables the pair ties (frame members left out)."""
        return tuple(v for v in (self.gear, self.mate, self.carrier) if v)


def _table(spec) -> Mapping:
    val = spec.get("gears", {})
    return val if isinstance(val, Mapping) else {}


def kind_hints(spec):
    for name, d in _table(spec).items():
        if not isinstance(d, Mapping):
            continue
        key = f"gears.{name}"
        for k in ("gear", "mate", "carrier"):
            if isinstance(d.get(k), str):
                yield d[k], "angle", f"{key}.{k}"
        if isinstance(d.get("rack"), str):
            yield d["rack"], "length", f"{key}.rack"
        for k in ("radii", "radius"):
            vals = d.get(k)
            for v in (vals if isinstance(vals, list) else [vals]):
                if isinstance(v, str) and _is_name(v):
                    yield v.strip(), "length", f"{key}.{k}"


def _is_name(text: str) -> bool:
    try:
        return isinstance(_expr.parse(text), _expr.Name)
    except Exception:
        return False


def names_used(spec):
    for name, d in _table(spec).items():
        if not isinstance(d, Mapping):
            continue
        key = f"gears.{name}"
        for k in ("gear", "mate", "carrier", "rack"):
            if isinstance(d.get(k), str) and d[k] not in ("frame", "ground"):
                yield d[k], key
        for k in ("teeth", "radii", "radius", "module", "phase"):
            vals = d.get(k)
            for v in (vals if isinstance(vals, list) else [vals]):
                if isinstance(v, str):
                    try:
                        yield from ((n, key) for n in _expr.names(_expr.parse(v)))
                    except Exception:
                        pass


def _teeth(ctx, raw, key, count: int):
    """``count`` tooth numbers: positive integers, or parameters holding them."""
    if not isinstance(raw, list) or len(raw) != count:
        ctx.problems.add(key, f"expected {count} tooth number(s) such as {[24, 36][:count]}, got {raw!r}")
        return None
    out = []
    for i, t in enumerate(raw):
        k = f"{key}[{i}]"
        if isinstance(t, bool) or not isinstance(t, (int, float, str)):
            ctx.problems.add(k, f"a tooth number is a positive integer (or an integer parameter), got {t!r}")
            return None
        node = ctx.quantity(t, k, Kind.DIMENSIONLESS)
        if node is None:
            return None
        v = ctx.value(node)
        if v is None or v < 1 or abs(v - round(v)) > 1e-9:
            ctx.problems.add(k, f"{t!r} = {v:g}: teeth are whole numbers, at least 1" if v is not None
                             else f"{t!r} is not a number")
            return None
        out.append(node)
    return tuple(out)


def _radii(ctx, raw, key, count: int):
    vals = raw if isinstance(raw, list) else [raw]
    if len(vals) != count:
        ctx.problems.add(key, f"expected {count} pitch radi{'us' if count == 1 else 'i'}, got {raw!r}")
        return None
    out = []
    for i, r in enumerate(vals):
        node = ctx.quantity(r, f"{key}[{i}]" if count > 1 else key, Kind.LENGTH, positive=True, allow_zero=False)
        if node is None:
            return None
        out.append(node)
    return tuple(out)


def parse(ctx) -> tuple[GearPair, ...]:
    out = []
    for name, raw in ctx.table("gears").items():
        d = ctx.entry("gears", name, raw, _KEYS, _EXAMPLE)
        if d is None:
            continue
        key = f"gears.{name}"
        pair = _parse_pair(ctx, str(name), key, d)
        if pair is not None:
            out.append(pair)
    return tuple(out)


def _parse_pair(ctx, name, key, d) -> GearPair | None:
    p = ctx.problems
    n_before = len(p.items)
    rack = "rack" in d
    if "gear" not in d:
        p.add(key, f"missing key 'gear' (the angle of the first gear), e.g. {_EXAMPLE}")
        return None
    if rack and "mate" in d:
        p.add(key, "give either `mate` (a gear) or `rack` (the rack's travel), not both")
        return None
    if not rack and "mate" not in d:
        p.add(key, f"missing key 'mate' (the angle of the second gear) or 'rack', e.g. {_EXAMPLE}")
        return None
    internal = d.get("internal", False)
    if not isinstance(internal, bool):
        p.add(f"{key}.internal", f"expected true or false, got {internal!r}")
        return None
    if rack and internal:
        p.add(f"{key}.internal", "a rack has no internal form")
        return None
    gear = ctx.variable(d["gear"], f"{key}.gear", Kind.ANGLE, frame=True)
    mate = (ctx.variable(d["rack"], f"{key}.rack", Kind.LENGTH) if rack
            else ctx.variable(d["mate"], f"{key}.mate", Kind.ANGLE, frame=True))
    carrier = ctx.variable(d.get("carrier", "frame"), f"{key}.carrier", Kind.ANGLE, frame=True)
    if gear is None or mate is None or carrier is None:
        return None
    if not rack and gear == mate:
        p.add(key, "a gear cannot mesh with itself: gear and mate name " + (repr(gear) if gear else "the frame"))
        return None
    if carrier and carrier in (gear, mate):
        p.add(f"{key}.carrier", f"{carrier!r} is a member of the pair: the carrier holds the gears' axes")
        return None
    if not rack and not gear and not mate:
        p.add(key, "both gears are the frame")
        return None
    count = 1 if rack else 2
    teeth = _teeth(ctx, d["teeth"], f"{key}.teeth", count) if "teeth" in d else None
    rkey = "radius" if rack else "radii"
    other = "radii" if rack else "radius"
    if other in d:
        p.add(f"{key}.{other}", f"unknown key for {'a rack' if rack else 'a gear pair'}: use `{rkey}`")
        return None
    radii = _radii(ctx, d[rkey], f"{key}.{rkey}", count) if rkey in d else None
    module = ctx.quantity(d["module"], f"{key}.module", Kind.LENGTH, positive=True, allow_zero=False) \
        if "module" in d else None
    if len(p.items) > n_before:
        return None
    if module is not None and teeth is None:
        p.add(f"{key}.module", "a module needs `teeth` (the pitch radii are m·N/2)")
        return None
    if teeth is None and radii is None:
        p.add(key, f"give `teeth` (tooth numbers) or `{rkey}` (pitch radi{'us' if rack else 'i'})")
        return None
    if module is not None and radii is not None:
        p.add(f"{key}.module", f"give `module` or `{rkey}`, not both (the module fixes the radii)")
        return None
    if teeth is not None and radii is not None and not rack:
        ng, nm = (ctx.value(t) for t in teeth)
        rg, rm = (ctx.value(r, Kind.LENGTH) for r in radii)
        if abs(rg / rm - ng / nm) > 1e-9 * (ng / nm):
            p.add(key, f"the pitch radii {rg:g} and {rm:g} ({ctx.length_unit}) are not in the ratio of the teeth "
                  f"{ng:g}:{nm:g}: one pitch (module) for both gears means r_gear/r_mate = N_gear/N_mate")
            return None
    if internal and teeth is not None:
        ng, nm = (ctx.value(t) for t in teeth)
        if ng == nm:
            p.add(f"{key}.teeth", "an internal pair needs a ring with more teeth than its pinion")
            return None
    if rack and teeth is not None and module is None and radii is None:
        p.add(f"{key}.module", "a rack's pinion needs its pitch radius: give `radius`, or `module` with `teeth`")
        return None
    pa = ctx.angle(d.get("pressure_angle", "20deg"), f"{key}.pressure_angle")
    if pa is None:
        return None
    if not 0 <= pa < math.radians(45):
        p.add(f"{key}.pressure_angle", f"{d.get('pressure_angle')!r} is outside 0 to 45 degrees")
        return None
    centers = d.get("centers", [])
    if centers != []:
        if not isinstance(centers, list) or len(centers) != (1 if rack else 2):
            p.add(f"{key}.centers", f"expected the {'pinion centre' if rack else 'two centres'} as point names, "
                  f"e.g. {['O2'] if rack else ['O2', 'O5']}, got {centers!r}")
            return None
        names = [ctx.point(c, f"{key}.centers[{i}]") for i, c in enumerate(centers)]
        if None in names:
            return None
        centers = tuple(names)
    else:
        centers = ()
    phase, ref = None, ()
    if "phase" in d:
        phase = ctx.quantity(d["phase"], f"{key}.phase", Kind.LENGTH if rack else Kind.ANGLE)
        if phase is None:
            return None
    else:
        missing = [v for v in (gear, mate, carrier) if v and ctx.variables[v].guess is None]
        if missing:
            p.add(key, f"no phase and no guess for {', '.join(missing)}: the phase defaults to what the guesses "
                  "give (the pair meshes at the guessed pose); give guesses or `phase`")
            return None
        ref = tuple(ctx.variables[v].guess if v else 0.0 for v in (gear, mate, carrier))
    kind = "rack" if rack else "internal" if internal else "external"
    text = _describe(kind, gear, mate, carrier, d)
    return GearPair(name, key, kind, gear, mate, carrier, teeth, radii, module, phase, ref, pa, centers, text)


def _describe(kind, gear, mate, carrier, d) -> str:
    g = gear or "frame"
    c = f" on carrier {carrier}" if carrier else ""
    if kind == "rack":
        return f"rack {mate} driven by pinion {g}{c}"
    how = f"teeth {d['teeth']}" if "teeth" in d else f"radii {d['radii']}"
    return f"{kind} pair {g} : {mate or 'frame'}{c}, {how}"


def ratio_values(pair: GearPair, values) -> tuple[float | None, float | None, float]:
    """``(r_gear, r_mate, N_gear/N_mate)`` of a pair, with ``values(node, kind)`` evaluating its expressions
    (radii ``None`` when only teeth are known; a rack's ratio is its pinion radius)."""
    if pair.rack:
        if pair.radii is not None:
            r = values(pair.radii[0], Kind.LENGTH)
        else:
            r = values(pair.module, Kind.LENGTH) * values(pair.teeth[0], Kind.DIMENSIONLESS) / 2
        return r, None, r
    if pair.radii is not None:
        rg, rm = (values(r, Kind.LENGTH) for r in pair.radii)
        return rg, rm, rg / rm
    ng, nm = (values(t, Kind.DIMENSIONLESS) for t in pair.teeth)
    if pair.module is not None:
        m = values(pair.module, Kind.LENGTH)
        return m * ng / 2, m * nm / 2, ng / nm
    return None, None, ng / nm


def teeth_parameters(mech) -> set[str]:
    """The parameters that are tooth numbers of a gear pair (whole numbers: studies and synthesis vary them
    over the integers)."""
    out = set()
    if mech.pairs is None:
        return out
    for g in mech.pairs.gears:
        for t in g.teeth or ():
            if isinstance(t, _expr.Name):
                out.add(t.id)
    return out
