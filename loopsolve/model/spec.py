"""Building and validating a Mechanism from its specification, the TOML-shaped ``dict``.

:func:`build_mechanism` is the one place a :class:`loopsolve.model.mechanism.Mechanism` is made: the model
file (:mod:`loopsolve.model.modelfile`), diagram models (:mod:`loopsolve.model.diagram`) and the Python
:class:`loopsolve.model.builder.MechanismBuilder` all go through it. Every problem of a declaration is
collected and reported at once, each naming the key (``vectors.r3.angle``) and the offending
text; expressions are parsed by :mod:`loopsolve.model.expr` (never evaluated as Python), their units
inferred and checked, their size bounded (:mod:`loopsolve.model.exprcheck`).
"""

from __future__ import annotations

import difflib
import keyword
import math
import re
from collections.abc import Mapping
from typing import Any

from . import expr as _expr
from .bodies import parse_dynamics
from ..errors import ModelError, ModelFileError
from .exprcheck import ExpressionTooLarge, check_literals, check_terms, constant_size, degree_bound, nesting_depth
from .mechanism import Loop, Mechanism, Parameter, Point, Units, Variable, Vector, deep_copy
from . import pairs as _pairs
from .vectorsum import NotLinear, linear_in_vectors
from .units import MAX_MAGNITUDE, Kind, UnitError, parse_quantity, unit_kind, units_of_kind, validate_units

__all__ = ["build_mechanism"]

RESERVED = frozenset({"sin", "cos", "tan", "sqrt", "asin", "acos", "atan", "atan2", "abs", "pi"}
                     | set(keyword.kwlist))
_NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
#: loop names and mode names: printable, one line, bounded
_LABEL_RE = re.compile(r"[A-Za-z][A-Za-z0-9_ .-]{0,63}\Z")
_TERM_RE = re.compile(r"\s*([+-]?)\s*([A-Za-z][A-Za-z0-9_]*)\s*")

#: expression contexts used to infer whether a symbol is an angle or a length
_ANGLE, _LENGTH, _ANY = "angle", "length", "any"





class Problems:
    """The problems of one model, collected and raised together (one error naming each key)."""
    def __init__(self, source: str | None):
        self.source = source
        self.items: list[tuple[str, str]] = []

    def add(self, key: str, message: str) -> None:
        self.items.append((key, message))

    def raise_if_any(self) -> None:
        if not self.items:
            return
        where = self.source or "<python>"
        lines = [f"{where}: {key}: {msg}" if key else f"{where}: {msg}" for key, msg in self.items]
        if len(lines) == 1:
            message = lines[0]
        else:
            message = f"{len(lines)} problems in {where}:\n  " + "\n  ".join(lines)
        if self.source is not None:
            raise ModelFileError(message, path=self.source, key=self.items[0][0], problems=lines)
        raise ModelError(message, problems=lines)


def check_name(name: Any, key: str, problems: Problems) -> bool:
    """Whether ``name`` is a valid, unreserved name; the problem is added under ``key`` if not."""
    if not isinstance(name, str) or not _NAME_RE.match(name):
        problems.add(key, f"{name!r} is not a valid name (letters, digits and _, starting with a letter)")
        return False
    if name in RESERVED or "__" in name:
        problems.add(key, f"{name!r} is a reserved name; choose another")
        return False
    return True


def _parse_terms(text: Any, key: str, problems: Problems) -> tuple[tuple[int, str], ...] | None:
    """Parse ``a + b - c`` into signed names; ``0`` is the empty sum."""
    if not isinstance(text, str):
        problems.add(key, f"expected a string such as \"r2 + r3\", got {text!r}")
        return None
    s = text.strip()
    if s == "0":
        return ()
    terms: list[tuple[int, str]] = []
    pos = 0
    first = True
    while pos < len(s):
        m = _TERM_RE.match(s, pos)
        if not m or m.end() == pos or (not first and not m.group(1)):
            problems.add(
                key,
                f"cannot read {text!r} at column {pos + 1}: write a sum or difference of vector "
                "names such as \"r2 + r3 = r1 + r4\"",
            )
            return None
        terms.append((-1 if m.group(1) == "-" else 1, m.group(2)))
        pos = m.end()
        first = False
    if not terms:
        problems.add(key, f"empty vector sum in {text!r}")
        return None
    return tuple(terms)


def parse_point(pname: str, text: Any, key: str, problems: Problems, *, vec_names, param_names,
                var_names=()) -> Point | None:
    """Parse a point expression: a sum of vectors with optional scalar factors (``r2 + 0.5*r3``).

    A name that is a declared vector is a vector (even when a parameter has the same name); the
    factors are numbers, parameters and expressions of them (``k*r3``, ``(a/b)*r3``, ``r3/2``,
    ``0.5*(r2 + r3)``). ``"0"`` is the origin. Problems go to ``problems`` (``None`` returned).
    """
    if isinstance(text, str) and text.strip() == "0":
        return Point(pname, (), text)
    if isinstance(text, str) and _TERM_SUM_RE.match(text):
        terms = _parse_terms(text, key, problems)  # plain walk: the fast path, old messages
        if terms is None:
            return None
        bad = [n for _, n in terms if n not in vec_names]
        for n in bad:
            problems.add(key, f"{text!r} names the undeclared vector {n!r}; {_declared_vectors(sorted(vec_names))}")
        return None if bad else Point(pname, terms, text)
    if not isinstance(text, str):
        problems.add(key, f"expected a string such as \"r2 + 0.5*r3\", got {text!r}")
        return None
    node = _parse_expr(text, key, problems)
    if node is None:
        return None
    try:
        lin = linear_in_vectors(node, frozenset(vec_names))
    except NotLinear as exc:
        problems.add(key, f"cannot read {text!r} as a point: {exc}; write a sum of vectors with "
                     "scalar factors such as \"r2 + 0.5*r3\" or \"r2 + k*r3 - r7\"")
        return None
    if not lin:
        problems.add(key, f"{text!r} names no vector (write \"0\" for the origin)")
        return None
    ok = True
    for _, factor in lin:
        if factor is None:
            continue
        for nm in sorted(_expr.names(factor)):
            if nm in var_names:
                problems.add(key, f"{text!r}: the factor {_expr.to_text(factor)!r} uses the variable {nm!r}; "
                             "factors are numbers and parameters")
                ok = False
            elif nm not in param_names:
                problems.add(key, f"{text!r} names {nm!r}, which is neither a declared vector nor a "
                             f"parameter; {_declared_vectors(sorted(vec_names))}")
                ok = False
        for n in _expr.walk(factor):
            if isinstance(n, _expr.Num) and n.unit is not None:
                problems.add(key, f"{text!r}: a factor is a plain number, not {n.value:g}{n.unit}")
                ok = False
    if not ok:
        return None
    terms, factors = [], []
    for name, factor in lin:
        sign = 1
        if isinstance(factor, _expr.Num) and factor.unit is None and abs(factor.value) == 1.0:
            sign, factor = (1 if factor.value > 0 else -1), None
        elif isinstance(factor, _expr.Unary) and factor.op == "-":
            sign, factor = -1, factor.operand
            if isinstance(factor, _expr.Num) and factor.unit is None and factor.value == 1.0:
                factor = None
        terms.append((sign, name))
        factors.append(factor)
    return Point(pname, tuple(terms), text, tuple(factors) if any(f is not None for f in factors) else ())


_TERM_SUM_RE = re.compile(r"^\s*[+-]?\s*[A-Za-z][A-Za-z0-9_]*(\s*[+-]\s*[A-Za-z][A-Za-z0-9_]*)*\s*$")


def _parse_expr(value: Any, key: str, problems: Problems, moving: frozenset | None = None) -> _expr.Node | None:
    """Parse one expression field; its problems go to ``problems`` under ``key``.

    ``moving`` names the variables (for the size of the derivatives; ``None``: every name).
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        problems.add(key, f"expected a number or an expression string, got {value!r}")
        return None
    if isinstance(value, float) and not math.isfinite(value):
        problems.add(key, f"{value!r} is not a finite number")
        return None
    try:
        node = _expr.parse(value)
    except ModelError as exc:
        problems.add(key, str(exc))
        return None
    try:
        constant_size(node)
        degree_bound(node)
        nesting_depth(node)
        check_terms(node, moving)
    except ExpressionTooLarge as exc:
        problems.add(key, f"{exc} in {_short(value)!r}")
        return None
    return node


def _declared_vectors(names) -> str:
    """The tail of an 'undeclared vector' message (no empty list: a misspelt [vectors] leaves none)."""
    names = [str(n) for n in names]
    return ("declared vectors: " + ", ".join(names)) if names else "no vectors are declared ([vectors] table)"


def _short(value: Any, limit: int = 60) -> str:
    text = str(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _collect_kinds(node, ctx: str, key: str, out: dict[str, set], pi_uses: list, angle_unit: str):
    """Record in ``out[name]`` the contexts (angle/length) in which each name appears."""
    if isinstance(node, _expr.Name):
        if ctx != _ANY:
            out.setdefault(node.id, set()).add((ctx, key))
    elif isinstance(node, _expr.Const):
        if ctx == _ANGLE and angle_unit != "rad":
            pi_uses.append(key)
    elif isinstance(node, _expr.Unary):
        _collect_kinds(node.operand, ctx, key, out, pi_uses, angle_unit)
    elif isinstance(node, _expr.Binary):
        if node.op == "**":
            _collect_kinds(node.left, ctx, key, out, pi_uses, angle_unit)
            _collect_kinds(node.right, _ANY, key, out, pi_uses, angle_unit)
        else:
            _collect_kinds(node.left, ctx, key, out, pi_uses, angle_unit)
            _collect_kinds(node.right, ctx, key, out, pi_uses, angle_unit)
    elif isinstance(node, _expr.Call):
        sub = _ANGLE if node.func in ("sin", "cos", "tan") else _ANY
        for a in node.args:
            _collect_kinds(a, sub, key, out, pi_uses, angle_unit)


def name_and_units(spec: Mapping[str, Any], problems: Problems) -> tuple[str, Units]:
    """The ``name`` and ``units`` of a model (vector-loop or diagram layout), problems collected."""
    name = spec.get("name", "mechanism")
    if not isinstance(name, str) or not name.strip():
        problems.add("name", f"expected a non-empty string, got {name!r}")
        name = "mechanism"
    units_spec = spec.get("units", {})
    length_unit, angle_unit = "mm", "deg"
    if not isinstance(units_spec, Mapping):
        problems.add("units", f"expected a table like {{ length = \"mm\", angle = \"deg\" }}, got {units_spec!r}")
    else:
        for k in units_spec:
            if k not in ("length", "angle"):
                problems.add(f"units.{k}", "unknown key (expected `length` and `angle`)")
        length_unit = units_spec.get("length", "mm")
        angle_unit = units_spec.get("angle", "deg")
        try:
            validate_units(angle_unit, length_unit)
        except (UnitError, ModelError) as exc:
            problems.add("units", str(exc))
            length_unit, angle_unit = "mm", "deg"
    return name.strip(), Units(length=length_unit, angle=angle_unit)


def build_mechanism(spec: Mapping[str, Any], *, source: str | None = None) -> Mechanism:
    """Validate a model ``dict`` (the TOML layout) and return the :class:`Mechanism`.

    Every problem is collected; one :class:`ModelError` (``ModelFileError`` when ``source``
    names a file) reports them all.

    Parameters
    ----------
    spec : mapping
        The model as a ``dict`` with the keys of a model file.
    source : str, optional
        The file it came from, named in errors.

    Returns
    -------
    Mechanism

    Examples
    --------
    >>> spec = {"parameters": {"r2": 25, "r3": 70},
    ...         "variables": {"theta2": {"input": True, "guess": 30}, "theta3": {"guess": -10},
    ...                       "x": {"guess": 90}},
    ...         "vectors": {"r1": {"length": "x", "angle": 0}, "r2": {"length": "r2", "angle": "theta2"},
    ...                     "r3": {"length": "r3", "angle": "theta3"}},
    ...         "loops": [{"equation": "r2 + r3 = r1"}]}
    >>> mech = ls.build_mechanism(spec)
    >>> round(mech.solve(90)["x"], 4)
    65.3835
    """
    problems = Problems(source)
    if not isinstance(spec, Mapping):
        problems.add("", "a model is a table of keys (name, units, parameters, ...)")
        problems.raise_if_any()

    known_top = {"name", "units", "parameters", "variables", "vectors", "loops", "points",
                 "description", "schema", "links", "joints", "input", "version", "modes",
                 "gravity", "bodies", "loads"} | set(_pairs.SECTIONS)
    for k in spec:
        if k not in known_top:
            near = difflib.get_close_matches(str(k), known_top, n=1)
            hint = f"did you mean {near[0]!r}? " if near else ""
            problems.add(str(k), f"unknown key {k!r} ({hint}expected one of: {', '.join(sorted(known_top))})")

    name, units = name_and_units(spec, problems)
    length_unit, angle_unit = units.length, units.angle

    def section(key: str) -> Mapping[str, Any]:
        val = spec.get(key, {})
        if not isinstance(val, Mapping):
            problems.add(key, f"expected a table, got {type(val).__name__} {val!r}")
            return {}
        return val

    param_spec = section("parameters")
    var_spec = section("variables")
    vec_spec = section("vectors")
    point_spec = section("points")
    loops_spec = spec.get("loops", [])
    if not isinstance(loops_spec, list):
        problems.add("loops", "expected an array of tables: [[loops]] equation = \"r2 + r3 = r1 + r4\"")
        loops_spec = []

    for pname in param_spec:
        check_name(pname, f"parameters.{pname}", problems)
    for vname in var_spec:
        check_name(vname, f"variables.{vname}", problems)
        if vname in param_spec:
            problems.add(f"variables.{vname}", f"{vname!r} is declared both as a parameter and as a variable")
    for vname in vec_spec:
        check_name(vname, f"vectors.{vname}", problems)
    if not var_spec:
        problems.add("variables", "no joint variables declared")
    n_pair_rows = _pairs.declared_rows(spec)
    if not vec_spec and not n_pair_rows:
        problems.add("vectors", "no vectors declared")
    if not loops_spec and not n_pair_rows:
        problems.add("loops", "no vector loops declared: add [[loops]] equation = \"...\"")

    # ---- vectors (parse expressions)
    moving = frozenset(str(n) for n in var_spec)
    vectors: list[Vector] = []
    vec_keys_polar = {"length", "angle", "offset", "link"}
    vec_keys_cart = {"x", "y", "link"}
    for vname, vdef in vec_spec.items():
        key = f"vectors.{vname}"
        if not isinstance(vdef, Mapping):
            problems.add(key, f"expected {{ length = ..., angle = ... }} or {{ x = ..., y = ... }}, got {vdef!r}")
            continue
        keys = set(vdef)
        if "x" in keys or "y" in keys:
            extra = keys - vec_keys_cart
            if extra or not {"x", "y"} <= keys:
                problems.add(key, "a Cartesian vector needs exactly `x` and `y` "
                             f"(got keys {sorted(keys)})")
                continue
            x = _parse_expr(vdef["x"], f"{key}.x", problems, moving)
            y = _parse_expr(vdef["y"], f"{key}.y", problems, moving)
            vectors.append(Vector(vname, x=x, y=y))
        else:
            extra = keys - vec_keys_polar
            missing = {"length", "angle"} - keys
            if extra:
                problems.add(key, f"unknown key(s) {sorted(extra)} (allowed: length, angle, offset, or x, y)")
            if missing:
                problems.add(key, f"missing key(s) {sorted(missing)}")
            if extra or missing:
                continue
            ln = _parse_expr(vdef["length"], f"{key}.length", problems, moving)
            an = _parse_expr(vdef["angle"], f"{key}.angle", problems, moving)
            off = _parse_expr(vdef["offset"], f"{key}.offset", problems, moving) if "offset" in vdef else None
            vectors.append(Vector(vname, length=ln, angle=an, offset=off))

    # ---- infer kinds from the contexts the names appear in
    seen: dict[str, set] = {}
    pi_uses: list[str] = []
    for v in vectors:
        key = f"vectors.{v.name}"
        if v.cartesian:
            for f_, n in (("x", v.x), ("y", v.y)):
                if n is not None:
                    _collect_kinds(n, _LENGTH, f"{key}.{f_}", seen, pi_uses, angle_unit)
        else:
            if v.length is not None:
                _collect_kinds(v.length, _LENGTH, f"{key}.length", seen, pi_uses, angle_unit)
            if v.angle is not None:
                _collect_kinds(v.angle, _ANGLE, f"{key}.angle", seen, pi_uses, angle_unit)
            if v.offset is not None:
                _collect_kinds(v.offset, _ANGLE, f"{key}.offset", seen, pi_uses, angle_unit)
    for v in vectors:
        for f_, ctx in (("length", _LENGTH), ("angle", _ANGLE), ("offset", _ANGLE), ("x", _LENGTH),
                        ("y", _LENGTH)):
            n = getattr(v, f_)
            if n is not None:
                check_literals(n, ctx, f"vectors.{v.name}.{f_}", problems, angle_unit, length_unit,
                                _short(vec_spec[v.name][f_]))
    for key in pi_uses:
        problems.add(key, "`pi` in an angle of a model whose angles are in degrees would mean "
                          "pi degrees: write the angle in degrees (180 for pi), or set "
                          "units.angle = \"rad\"")
    # every name used anywhere (also inside sqrt(), abs(), exponents, where no kind is inferred)
    used: dict[str, str] = {}
    for v in vectors:
        for f_ in ("length", "angle", "offset", "x", "y"):
            n = getattr(v, f_)
            if n is not None:
                for nm in sorted(_expr.names(n)):
                    used.setdefault(nm, f"vectors.{v.name}.{f_}")
    for nm, where in used.items():
        if nm not in param_spec and nm not in var_spec:
            problems.add(where, f"unknown name {nm!r} (not a parameter or variable); declared: "
                         + ", ".join(list(param_spec) + list(var_spec)))
    _pairs.infer_kinds(spec, seen)  # higher pairs name variables too (gear angles, a rack's travel...)
    pair_names = _pairs.pair_variables(spec)
    for nm, where in pair_names.items():
        used.setdefault(nm, where)

    def kind_of(nm: str) -> Kind | None:
        ctxs = {c for c, _ in seen.get(nm, ())}
        if ctxs == {_ANGLE}:
            return Kind.ANGLE
        if ctxs == {_LENGTH}:
            return Kind.LENGTH
        if not ctxs:
            return None
        keys = sorted(k for _, k in seen[nm])
        problems.add(keys[0], f"{nm!r} is used both as an angle and as a length (in {', '.join(keys)})")
        return None

    # ---- parameters
    parameters: list[Parameter] = []
    for pname, pval in param_spec.items():
        key = f"parameters.{pname}"
        kind = kind_of(pname)
        if isinstance(pval, bool) or not isinstance(pval, (int, float, str)):
            problems.add(key, f"a parameter is a number (optionally with a unit, \"30deg\"), got {pval!r}")
            continue
        if isinstance(pval, str):
            unit_kind = _unit_kind_of_text(pval)
            if unit_kind is None:
                problems.add(key, f"{pval!r} is not a number; a parameter is a number, optionally "
                             "with a unit such as \"30deg\" or \"25mm\"")
                continue
            if unit_kind not in (Kind.ANGLE, Kind.LENGTH, Kind.DIMENSIONLESS):
                expected = f"{pname!r} is used as {_a(kind.value)}" if kind is not None else \
                    "a parameter is an angle, a length or a plain number"
                problems.add(key, f"{pval!r} has {_a(unit_kind.value)} unit; {expected} (accepted units: "
                             + ", ".join(units_of_kind(kind or Kind.ANGLE) + (() if kind else units_of_kind(Kind.LENGTH)))
                             + ")")
                continue
            if kind is None:
                kind = unit_kind
            elif unit_kind not in (kind, Kind.DIMENSIONLESS):
                problems.add(key, f"{pval!r} has {_a(unit_kind.value)} unit but {pname!r} is used as "
                             f"{_a(kind.value)}")
                continue
        qkind = kind if kind in (Kind.ANGLE, Kind.LENGTH) else None
        try:
            if qkind is None:
                value = float(pval) if not isinstance(pval, str) else float(pval.strip())
            else:
                value = parse_quantity(pval, qkind, angle_unit=angle_unit, length_unit=length_unit)
        except OverflowError:
            problems.add(key, f"{_short(pval)} is too large for a float")
            continue
        except (ValueError, ModelError) as exc:
            problems.add(key, str(exc))
            continue
        if not math.isfinite(value):
            problems.add(key, f"{pval!r} is not a finite number")
            continue
        if kind is not Kind.ANGLE and abs(value) > MAX_MAGNITUDE:
            problems.add(key, f"{_short(pval)} is beyond ±{MAX_MAGNITUDE:g}: values that large overflow the "
                         "squares and products the solver forms (use a larger unit)")
            continue
        parameters.append(Parameter(pname, value, kind or Kind.DIMENSIONLESS, str(pval)))

    # ---- variables
    variables: list[Variable] = []
    var_keys = {"input", "guess", "speed", "accel", "jerk", "kind"}
    for vname, vdef in var_spec.items():
        key = f"variables.{vname}"
        if not isinstance(vdef, Mapping):
            problems.add(key, f"expected a table like {{ guess = 20 }}, got {vdef!r}")
            continue
        extra = set(vdef) - var_keys
        if extra:
            problems.add(key, f"unknown key(s) {sorted(extra)} (allowed: {', '.join(sorted(var_keys))})")
        kind = kind_of(vname)
        declared_kind = vdef.get("kind")
        if declared_kind is not None:
            dk = {"angle": Kind.ANGLE, "length": Kind.LENGTH}.get(declared_kind)
            if dk is None:
                problems.add(f"{key}.kind", f"{declared_kind!r}: expected \"angle\" or \"length\"")
            elif kind is not None and dk is not kind:
                problems.add(f"{key}.kind", f"declared {declared_kind} but used as a {kind.name.lower()}")
            kind = dk or kind
        if kind is None:
            if vname not in used:
                problems.add(key, f"variable {vname!r} is not used by any vector or higher pair")
            elif vname not in seen:
                problems.add(key, f"cannot tell whether {vname!r} is an angle or a length from its use in "
                             f"{used[vname]}: add kind = \"angle\" or kind = \"length\"")
            continue
        inp = vdef.get("input", False)
        if not isinstance(inp, bool):
            problems.add(f"{key}.input", f"expected true or false, got {inp!r}")
            inp = False
        rate_kinds = (
            (Kind.ANGULAR_RATE, Kind.ANGULAR_ACCEL, Kind.ANGULAR_JERK)
            if kind is Kind.ANGLE
            else (Kind.LENGTH_RATE, Kind.LENGTH_ACCEL, Kind.LENGTH_JERK)
        )
        vals: dict[str, float | None] = {}
        for fname, fkind in (("guess", kind), ("speed", rate_kinds[0]), ("accel", rate_kinds[1]),
                             ("jerk", rate_kinds[2])):
            raw = vdef.get(fname)
            if raw is None:
                vals[fname] = None
                continue
            try:
                # the problem list prefixes the key itself (no `where=`, or it would appear twice)
                vals[fname] = parse_quantity(raw, fkind, angle_unit=angle_unit, length_unit=length_unit)
            except (ModelError, ValueError, TypeError) as exc:
                problems.add(f"{key}.{fname}", str(exc))
                vals[fname] = None
        if not inp and any(vals[f] is not None for f in ("speed", "accel", "jerk")):
            problems.add(key, "speed/accel/jerk are given only for the input variable")
        variables.append(Variable(vname, kind, vals["guess"], inp, vals["speed"], vals["accel"], vals["jerk"]))

    n_inputs = sum(v.input for v in variables)
    if variables and n_inputs == 0:
        problems.add("variables", "no input: mark the driven variable with `input = true`")

    # ---- loops
    vec_names = set(vec_spec)
    loops: list[Loop] = []
    loop_names: dict[str, str] = {}
    for i, ldef in enumerate(loops_spec):
        key = f"loops[{i}]"
        if isinstance(ldef, str):
            ldef = {"equation": ldef}
        if not isinstance(ldef, Mapping) or "equation" not in ldef:
            problems.add(key, "expected a table with `equation = \"r2 + r3 = r1 + r4\"`")
            continue
        extra = set(ldef) - {"equation", "name"}
        if extra:
            problems.add(key, f"unknown key(s) {sorted(extra)} (allowed: equation, name)")
        text = ldef["equation"]
        lname = ldef.get("name", f"loop{i + 1}")
        if not isinstance(lname, str) or not _LABEL_RE.match(lname):
            problems.add(f"{key}.name", f"{_short(repr(lname))} is not a valid loop name (up to 64 letters, "
                         "digits, _, -, . and spaces, starting with a letter)")
            lname = f"loop{i + 1}"
        elif lname in loop_names:
            problems.add(f"{key}.name", f"loop name {lname!r} is used twice (also {loop_names[lname]})")
        loop_names.setdefault(lname, key)
        if not isinstance(text, str):
            problems.add(f"{key}.equation", f"expected a string, got {text!r}")
            continue
        sides = text.split("=")
        if len(sides) > 2:
            problems.add(f"{key}.equation", f"more than one '=' in {text!r}")
            continue
        lhs = _parse_terms(sides[0], f"{key}.equation", problems)
        rhs = _parse_terms(sides[1], f"{key}.equation", problems) if len(sides) == 2 else ()
        if lhs is None or rhs is None:
            continue
        bad = [n for _, n in lhs + rhs if n not in vec_names]
        for n in bad:
            problems.add(f"{key}.equation", f"{text!r} names the undeclared vector {n!r}; "
                         f"{_declared_vectors(vec_spec)}")
        if bad:
            continue
        terms = lhs + tuple((-s, n) for s, n in rhs)
        loops.append(Loop(str(lname), terms, text, lhs, rhs))

    # ---- points
    points: list[Point] = []
    for pname, pdef in point_spec.items():
        key = f"points.{pname}"
        check_name(pname, key, problems)
        pt = parse_point(pname, pdef, key, problems, vec_names=vec_names, param_names=set(param_spec),
                         var_names=set(var_spec))
        if pt is not None:
            points.append(pt)

    _check_links(vectors, loops if len(loops) == len(loops_spec) else None, parameters, variables, problems,
                 set(pair_names), _pairs.slot_vectors(spec, {p.name: p for p in points}))

    # ---- counts: from the declared names, so they are reported with every other problem
    declared_inputs = [n for n, d in var_spec.items() if isinstance(d, Mapping) and d.get("input") is True]
    if var_spec and (loops_spec or n_pair_rows) and declared_inputs:
        n_eq = 2 * len(loops_spec) + n_pair_rows
        n_unknown = len(var_spec) - len(declared_inputs)
        if n_unknown != n_eq:
            unknown = ", ".join(n for n in var_spec if n not in declared_inputs)
            if n_pair_rows:
                what = (f"{n_eq} scalar equations ({2 * len(loops_spec)} from {len(loops_spec)} loop(s), "
                        f"{n_pair_rows} from {', '.join(_pairs.declared_row_keys(spec))}): each loop gives two "
                        "equations (x and y) and each constraint, gear pair, cam, slot or rolling contact one, so "
                        "the unknowns must number the equations")
            else:
                what = (f"{n_eq} scalar loop equations from {len(loops_spec)} loop(s): each loop gives two "
                        "equations (x and y), so the unknowns must number twice the loops")
            problems.add(
                "variables",
                f"{n_unknown} unknown variable(s) ({unknown}) but {what}; "
                f"{len(declared_inputs)} input(s) declared ({', '.join(declared_inputs)}) "
                f"where these {len(var_spec)} variables and {n_eq} equations leave a mobility of "
                f"{len(var_spec) - n_eq}",
            )
    # ---- assembly-mode aliases: name -> signature ("open" = "-" for a four-bar)
    modes_spec = spec.get("modes", {})
    mode_aliases: dict[str, str] = {}
    if not isinstance(modes_spec, Mapping):
        problems.add("modes", "expected a table of alias = \"signature\" (e.g. open = \"-\")")
    else:
        n_unknown = max(2 * len(loops_spec) + n_pair_rows, 1)
        for alias, sig in modes_spec.items():
            if not isinstance(alias, str) or not _LABEL_RE.match(alias):
                problems.add(f"modes.{_short(repr(alias), 40)}", "a mode name is up to 64 letters, digits, _, -, . "
                             "and spaces, starting with a letter")
            elif not isinstance(sig, str) or not sig or set(sig) - {"+", "-"}:
                problems.add(f"modes.{alias}", f"a mode signature is a string of + and - signs, got {_short(repr(sig))}")
            elif len(sig) > n_unknown:
                problems.add(f"modes.{alias}", f"the signature {sig!r} has {len(sig)} signs but this model's "
                             f"signatures have at most {n_unknown} (one per diagonal block of the Jacobian)")
            else:
                mode_aliases[str(alias)] = sig
    dynamics = _dynamics(spec, problems, vectors, points, vec_names, param_spec, var_spec, units)
    pairs = _pairs.parse_pairs(_pairs.PairContext(
        problems=problems, parse_expr=lambda v, k: _parse_expr(v, k, problems, moving),
        check_literals=lambda n, c, k, t: check_literals(n, c, k, problems, angle_unit, length_unit, t),
        check_name=lambda n, k: check_name(n, k, problems),
        parameters={p.name: p for p in parameters}, variables={v.name: v for v in variables},
        vectors={v.name: v for v in vectors}, points={p.name: p for p in points},
        bodies=tuple(b.name for b in dynamics.bodies) if dynamics else (),
        links=_pairs.declared_links(spec, dynamics), angle_unit=angle_unit, length_unit=length_unit,
        dynamics=dynamics, spec=spec, loops=tuple(loops)))
    problems.raise_if_any()
    return Mechanism(
        name=name.strip(),
        units=units,
        parameters=tuple(parameters),
        variables=tuple(variables),
        vectors=tuple(vectors),
        loops=tuple(loops),
        points=tuple(points),
        source=source,
        spec=deep_copy(spec),
        mode_aliases=mode_aliases,
        dynamics=dynamics,
        pairs=pairs,
    )


def checked_links(vectors, parameters, variables) -> list:
    """The vectors whose length must be positive: links (a moving angle) of a constant length.

    Only lengths that are sums and products of length parameters and plain numbers are checked
    (the rule of a model file, and of every design of a study).
    """
    var_names = {v.name for v in variables}
    lengths = {p.name for p in parameters if p.kind is not Kind.ANGLE}
    out = []
    for v in vectors:
        if v.cartesian or v.length is None:
            continue
        moving_angle = (_expr.names(v.angle) | (_expr.names(v.offset) if v.offset is not None else set())) & var_names
        if not moving_angle or _expr.names(v.length) & var_names:
            continue
        if any(isinstance(n, (_expr.Call, _expr.Const)) or (isinstance(n, _expr.Num) and n.unit)
               for n in _expr.walk(v.length)) or not _expr.names(v.length) <= lengths:
            continue
        out.append(v)
    return out


def link_length_problem(v, value: float) -> str:
    """Why a link of length ``value`` <= 0 is refused (the model-file message)."""
    return (f"the link {v.name} (angle {_expr.to_text(v.angle)}) has length {_expr.to_text(v.length)} = {value:g}: "
            "a link's length must be positive (a zero length leaves its angle undetermined; for the opposite "
            "direction add 180 to the angle)")


def _check_links(vectors, loops, parameters, variables, problems: Problems, in_pairs=frozenset(),
                 pair_vectors=frozenset()) -> None:
    """Links of nonzero positive length, and every variable in some loop.

    A vector whose angle varies but whose length is a constant is a link: a length of zero leaves
    its angle undetermined, a negative one silently turns it by 180° (``info`` refuses both), so
    both are refused. A constant vector (fixed angle) may have length zero (no offset) or a
    negative one (pointing the other way). A variable used only by vectors outside every loop
    is never determined (an unknown) or drives nothing (an input: every rate would be 0).
    """
    env = {p.name: p.value for p in parameters if p.kind is not Kind.ANGLE}
    for v in checked_links(vectors, parameters, variables):
        try:
            value = _expr.evaluate(v.length, env)
        except ModelError:
            continue
        if value <= 0:
            problems.add(f"vectors.{v.name}.length", link_length_problem(v, value))
    if loops is None:  # a loop could not be read: its vectors are unknown
        return
    in_loops = {n for lp in loops for _, n in lp.terms} | set(pair_vectors)  # a slot's pin and line are in Φ too
    for var in variables:
        users = [v.name for v in vectors if var.name in _vector_names(v)]
        if users and not any(u in in_loops for u in users) and var.name not in in_pairs:
            problems.add(f"variables.{var.name}", f"{'the input ' if var.input else ''}{var.name!r} appears in no "
                         f"loop: the vector(s) {', '.join(users)} using it are in no loop equation, so it "
                         f"{'drives nothing (every rate would be 0)' if var.input else 'is never determined'}; "
                         "add them to a loop")


def _vector_names(v) -> set:
    out = set()
    for f_ in ("length", "angle", "offset", "x", "y"):
        n = getattr(v, f_)
        if n is not None:
            out |= _expr.names(n)
    return out


def _dynamics(spec, problems: Problems, vectors, points, vec_names, param_spec, var_spec, units):
    """``gravity``, ``[bodies]`` and ``[[loads]]`` (see :mod:`loopsolve.model.bodies`), problems collected."""
    if not any(k in spec for k in ("gravity", "bodies", "loads")):
        return None
    variables = set(var_spec)
    moving = {v.name for v in vectors
              if any(_expr.names(n) & variables for n in (v.length, v.angle, v.offset, v.x, v.y) if n is not None)}
    fixed = {p.name for p in points if not any(n in moving for _, n in p.terms)}
    by_vec = {v.name: v for v in vectors}

    def angle_text(vname):
        v = by_vec.get(vname)
        if v is None:
            return None
        if v.cartesian:
            return None if vname not in moving else f"<direction of {vname}>"
        return _expr.to_text(v.angle) if _expr.names(v.angle) & variables else None

    return parse_dynamics(
        spec, problems=problems,
        parse_point=lambda n, t, k: parse_point(n, t, k, problems, vec_names=vec_names,
                                                param_names=set(param_spec), var_names=variables),
        parse_expr=lambda v, k: _parse_expr(v, k, problems),
        vec_names=vec_names, point_names={p.name: p for p in points}, param_names=list(param_spec),
        var_names=list(var_spec), fixed_points=fixed, vector_angle_text=angle_text,
        length_unit=units.length, angle_unit=units.angle)


def _unit_kind_of_text(text: str) -> Kind | None:
    """Kind of the unit a quantity string carries (DIMENSIONLESS for a bare number), None if not a quantity."""
    s = text.strip()
    try:
        float(s)
        return Kind.DIMENSIONLESS
    except ValueError:
        pass
    for kind in (Kind.ANGLE, Kind.LENGTH):
        try:
            parse_quantity(s, kind, angle_unit="rad", length_unit="mm")
            return kind
        except (ModelError, ValueError):
            continue
    m = re.match(r"\s*[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\s*(.+?)\s*\Z", s)
    if m:  # a unit of another kind (a rate, a mass...)
        try:
            return unit_kind(m.group(1))
        except UnitError:
            return None
    return None


def _a(noun: str) -> str:
    return ("an " if noun[:1] in "aeiou" else "a ") + noun
