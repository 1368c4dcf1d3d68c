"""A small, safe expression language for model files.

Model files are data: expressions such as ``theta4 + 30deg`` or ``sqrt(a**2 + b**2)`` are
tokenized with a regular expression and parsed by a recursive-descent parser into a tree
of frozen dataclasses.  Nothing is ever passed to ``eval``, ``exec``, ``compile`` or
Python's ``ast``; anything outside the grammar raises :class:`ExpressionError`.

Grammar (``**`` is right-associative and binds tighter than unary minus)::

    expr   := term (('+' | '-') term)*
    term   := unary (('*' | '/') unary)*
    unary  := ('+' | '-') unary | power
    power  := atom ('**' unary)?
    atom   := NUMBER [UNIT] | 'pi' | NAME | FUNC '(' args ')' | '(' expr ')'

Functions: ``sin cos tan asin acos atan sqrt abs`` (one argument) and ``atan2(y, x)``.
A number may carry a unit (``30deg``, ``10 rpm``, ``2rad/s``, ``5°``): a word right after the
number (or after one space) that the units library (:mod:`loopsolve.model.units`) knows as a unit with
a dimension, continued by ``/word`` parts while the longer text is an angle, a length or one of
their rates (``2rad/s``, ``10rev/min``; ``30deg/k`` is ``30deg`` divided by ``k``). The unit must end at a
word boundary (``2radius`` is not ``2rad``).
"""

from __future__ import annotations

import keyword
import math
import numbers
import re
from dataclasses import dataclass
from typing import Iterator, Mapping, Union

from loopsolve.errors import ModelError
from .units import Kind, UnitError, unit_info, unit_kind

__all__ = [
    "ExpressionError",
    "Num",
    "Name",
    "Const",
    "Unary",
    "Binary",
    "Call",
    "Node",
    "FUNCTIONS",
    "CONSTANTS",
    "MAX_LENGTH",
    "MAX_DEPTH",
    "parse",
    "names",
    "walk",
    "evaluate",
    "to_text",
]

#: longest accepted expression text (characters)
MAX_LENGTH = 1000
#: deepest accepted nesting of parentheses, signs and powers (the tree depth limit is twice this)
MAX_DEPTH = 100

#: allowed functions and their number of arguments
FUNCTIONS: Mapping[str, int] = {
    "sin": 1,
    "cos": 1,
    "tan": 1,
    "asin": 1,
    "acos": 1,
    "atan": 1,
    "atan2": 2,
    "sqrt": 1,
    "abs": 1,
}
#: named constants
CONSTANTS: Mapping[str, float] = {"pi": math.pi}

_ALLOWED_FUNCS = ", ".join(FUNCTIONS)


class ExpressionError(ModelError):
    """An expression cannot be parsed or evaluated.

    ``text`` is the full expression text and ``column`` the 1-based column of the
    offending token (``None`` when the problem is not tied to a position).
    """

    def __init__(self, message: str, *, text: str | None = None, column: int | None = None):
        super().__init__(message)
        self.text = text
        self.column = column


# --------------------------------------------------------------------------- tree


@dataclass(frozen=True, slots=True)
class Num:
    """A number literal, optionally with a unit suffix (``Num(30.0, 'deg')``)."""

    value: float
    unit: str | None = None


@dataclass(frozen=True, slots=True)
class Name:
    """A reference to a model symbol (variable or parameter)."""

    id: str


@dataclass(frozen=True, slots=True)
class Const:
    """A named constant (only ``pi``)."""

    name: str


@dataclass(frozen=True, slots=True)
class Unary:
    """A unary ``+`` or ``-``."""

    op: str
    operand: "Node"


@dataclass(frozen=True, slots=True)
class Binary:
    """A binary operation; ``op`` is one of ``+ - * / **``."""

    op: str
    left: "Node"
    right: "Node"


@dataclass(frozen=True, slots=True)
class Call:
    """A call of an allowed function; ``args`` is a tuple of nodes."""

    func: str
    args: tuple


Node = Union[Num, Name, Const, Unary, Binary, Call]

# --------------------------------------------------------------------------- tokenizer

_NUMBER = r"(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
_TOKEN_RE = re.compile(
    rf"""
    (?P<ws>[ \t\r\n]+)
  | (?P<num>{_NUMBER})
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*)
  | (?P<op>\*\*|[-+*/(),])
    """,
    re.VERBOSE,
)
_WORDCHAR_RE = re.compile(r"[A-Za-z0-9_]+")
# a unit candidate after a number: a word (or °), then /word parts (s, s2, s^2, s², min...)
_UNIT_RE = re.compile(r" ?((?:[A-Za-zµμ][A-Za-z0-9_]*|°)(?:/(?:[A-Za-z][A-Za-z0-9_]*)(?:\^[0-9]|[²³])?)*)")


def _kinematic(unit: str) -> bool:
    try:
        kind = unit_kind(unit)
    except UnitError:
        return False
    return kind.is_angular or kind.is_length


def _unit_at(text: str, pos: int) -> tuple[str, int] | None:
    """The longest unit with a dimension starting at ``pos`` (after a number): ``(unit, end)``."""
    m = _UNIT_RE.match(text, pos)
    if m is None:
        return None
    cand = m.group(1)
    start = m.start(1)
    while True:
        info = unit_info(cand)
        if info is not None and info.dims and ("/" not in cand or _kinematic(cand)):
            end = start + len(cand)
            if _WORDCHAR_RE.match(text, end) is None:
                return cand, end
        cut = cand.rfind("/")
        if cut < 0:
            return None
        cand = cand[:cut]

_CHAR_HINTS = {
    "^": "'^' is not a power operator here; use '**' (e.g. x**2)",
    ".": "attribute access is not allowed",
    "[": "indexing is not allowed",
    "]": "indexing is not allowed",
    "'": "strings are not allowed",
    '"': "strings are not allowed",
    ";": "only one expression is allowed",
    ":": "only arithmetic expressions are allowed",
    "=": "assignments and comparisons are not allowed",
    "<": "comparisons are not allowed",
    ">": "comparisons are not allowed",
    "!": "comparisons are not allowed",
    "{": "only arithmetic expressions are allowed",
    "}": "only arithmetic expressions are allowed",
    "@": "only arithmetic expressions are allowed",
    "%": "only + - * / ** are allowed",
    "&": "only + - * / ** are allowed",
    "|": "only + - * / ** are allowed",
    "~": "only + - * / ** are allowed",
    "\\": "only arithmetic expressions are allowed",
}


def _quote(text: str) -> str:
    return f'"{text}"' if '"' not in text else repr(text)


def _error(text: str, pos: int | None, what: str, hint: str = "") -> ExpressionError:
    tail = f" ({hint})" if hint else ""
    if pos is None:
        return ExpressionError(f"{what} in {_quote(text)}{tail}", text=text)
    return ExpressionError(
        f"{what} at column {pos + 1} in {_quote(text)}{tail}", text=text, column=pos + 1
    )


class _Tok:
    __slots__ = ("kind", "value", "unit", "pos", "src")

    def __init__(self, kind: str, value, pos: int, src: str, unit: str | None = None):
        self.kind = kind  # 'num', 'name', 'op', 'end'
        self.value = value
        self.unit = unit
        self.pos = pos
        self.src = src


def _tokenize(text: str) -> list[_Tok]:
    tokens: list[_Tok] = []
    pos = 0
    n = len(text)
    while pos < n:
        m = _TOKEN_RE.match(text, pos)
        if m is None:
            ch = text[pos]
            raise _error(text, pos, f"unexpected {ch!r}", _CHAR_HINTS.get(ch, ""))
        if m.group("ws"):
            pos = m.end()
            continue
        src = m.group(0)
        if m.group("num") is not None:
            value = float(m.group("num"))
            if not math.isfinite(value):
                shown = m.group("num") if len(m.group("num")) <= 40 else m.group("num")[:37] + "..."
                raise _error(text, pos, f"number {shown!r} is too large (beyond float range)")
            end = m.end()
            unit = _unit_at(text, end)
            if unit is not None:
                src = text[pos:unit[1]]
                tokens.append(_Tok("num", value, pos, src, unit[0]))
                pos = unit[1]
                continue
            w = _WORDCHAR_RE.match(text, end)
            if w is not None:
                raise _error(
                    text,
                    end,
                    f"unknown unit {w.group(0)!r} after number {m.group('num')!r}",
                    f"implicit multiplication is not supported: write "
                    f"{m.group('num')}*{w.group(0)}",
                )
            tokens.append(_Tok("num", value, pos, src, None))
        elif m.group("name") is not None:
            word = m.group("name")
            if word.startswith("_"):
                raise _error(text, pos, f"names starting with '_' are not allowed: {word!r}")
            if keyword.iskeyword(word) or keyword.issoftkeyword(word):
                raise _error(
                    text, pos, f"{word!r} is a reserved word",
                    "only arithmetic expressions are allowed",
                )
            tokens.append(_Tok("name", word, pos, src))
        else:
            tokens.append(_Tok("op", m.group("op"), pos, src))
        pos = m.end()
    tokens.append(_Tok("end", None, n, ""))
    return tokens


# --------------------------------------------------------------------------- parser


class _Parser:
    def __init__(self, text: str):
        self.text = text
        self.tokens = _tokenize(text)
        self.i = 0
        self.depth = 0

    # helpers
    @property
    def tok(self) -> _Tok:
        return self.tokens[self.i]

    def advance(self) -> _Tok:
        t = self.tokens[self.i]
        self.i += 1
        return t

    def at_op(self, *ops: str) -> bool:
        t = self.tok
        return t.kind == "op" and t.value in ops

    def unexpected(self, expecting: str = "") -> ExpressionError:
        t = self.tok
        if t.kind == "end":
            return _error(self.text, None, "unexpected end of expression", expecting)
        return _error(self.text, t.pos, f"unexpected {t.src!r}", expecting)

    # grammar
    def parse(self) -> Node:
        if self.tok.kind == "end":
            raise ExpressionError(f"empty expression {_quote(self.text)}", text=self.text)
        node = self.expr()
        if self.tok.kind != "end":
            t = self.tok
            if t.kind == "op" and t.value == ")":
                raise _error(self.text, t.pos, "unmatched ')'")
            if t.kind == "op" and t.value == ",":
                raise _error(
                    self.text, t.pos, "unexpected ','", "commas only separate atan2 arguments"
                )
            raise self.unexpected("expected an operator or the end of the expression")
        return node

    def expr(self) -> Node:
        node = self.term()
        while self.at_op("+", "-"):
            op = self.advance().value
            node = Binary(op, node, self.term())
        return node

    def term(self) -> Node:
        node = self.unary()
        while self.at_op("*", "/"):
            op = self.advance().value
            node = Binary(op, node, self.unary())
        return node

    def unary(self) -> Node:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise _error(
                self.text, self.tok.pos, f"expression is nested too deeply (limit {MAX_DEPTH})"
            )
        try:
            if self.at_op("+", "-"):
                op = self.advance().value
                return Unary(op, self.unary())
            return self.power()
        finally:
            self.depth -= 1

    def power(self) -> Node:
        base = self.atom()
        if self.at_op("**"):
            self.advance()
            return Binary("**", base, self.unary())
        return base

    def atom(self) -> Node:
        t = self.tok
        if t.kind == "num":
            self.advance()
            return Num(t.value, t.unit)
        if t.kind == "name":
            self.advance()
            word = t.value
            if self.at_op("("):
                if word in CONSTANTS:
                    raise _error(self.text, t.pos, f"{word!r} is a constant, not a function")
                if word not in FUNCTIONS:
                    raise _error(
                        self.text, t.pos,
                        f"unknown function {word!r} (allowed: {_ALLOWED_FUNCS})",
                    )
                return self.call(t)
            if word in FUNCTIONS:
                raise _error(
                    self.text, t.pos, f"function {word!r} must be called", f"e.g. {word}(x)"
                )
            if word in CONSTANTS:
                return Const(word)
            return Name(word)
        if t.kind == "op" and t.value == "(":
            self.advance()
            self.depth += 1
            try:
                node = self.expr()
            finally:
                self.depth -= 1
            if not self.at_op(")"):
                if self.tok.kind == "end":
                    raise _error(self.text, t.pos, "unclosed '('")
                raise self.unexpected("expected ')'")
            self.advance()
            return node
        raise self.unexpected("expected a number, a name or '('")

    def call(self, name_tok: _Tok) -> Node:
        func = name_tok.value
        open_tok = self.advance()  # '('
        args: list[Node] = []
        if not self.at_op(")"):
            self.depth += 1
            try:
                args.append(self.expr())
                while self.at_op(","):
                    self.advance()
                    args.append(self.expr())
            finally:
                self.depth -= 1
        if not self.at_op(")"):
            if self.tok.kind == "end":
                raise _error(self.text, open_tok.pos, f"unclosed '(' in call of {func}")
            raise self.unexpected(f"expected ',' or ')' in the call of {func}")
        self.advance()
        want = FUNCTIONS[func]
        if len(args) != want:
            plural = "argument" if want == 1 else "arguments"
            raise _error(
                self.text,
                name_tok.pos,
                f"{func}() takes exactly {want} {plural} (got {len(args)})",
            )
        return Call(func, tuple(args))


def _children(node: Node) -> tuple:
    if isinstance(node, Unary):
        return (node.operand,)
    if isinstance(node, Binary):
        return (node.left, node.right)
    if isinstance(node, Call):
        return node.args
    return ()


def _depth(node: Node) -> int:
    """Depth of a tree, computed without recursion."""
    best = 0
    stack = [(node, 1)]
    while stack:
        n, d = stack.pop()
        best = max(best, d)
        stack.extend((c, d + 1) for c in _children(n))
    return best


def parse(text: str | int | float) -> Node:
    """Parse an expression (or wrap a number) into a tree.

    Parameters
    ----------
    text : str, int or float
        Expression text; ints and floats become :class:`Num` directly (bools are
        rejected).

    Raises
    ------
    ExpressionError
        Anything outside the grammar, with the column of the offending token.

    Examples
    --------
    >>> parse("theta4 + 30deg")
    Binary(op='+', left=Name(id='theta4'), right=Num(value=30.0, unit='deg'))
    >>> parse("-x**2")
    Unary(op='-', operand=Binary(op='**', left=Name(id='x'), right=Num(value=2.0, unit=None)))
    >>> parse(2)
    Num(value=2.0, unit=None)
    >>> try:
    ...     parse("os.system('x')")
    ... except ExpressionError as exc:
    ...     print(exc)
    unexpected '.' at column 3 in "os.system('x')" (attribute access is not allowed)
    """
    if isinstance(text, bool):
        raise ExpressionError(f"expected an expression or a number, got the boolean {text!r}")
    if isinstance(text, numbers.Real):
        try:
            value = float(text)
        except OverflowError:
            value = math.inf
        if not math.isfinite(value):
            shown = repr(text) if len(repr(text)) <= 40 else repr(text)[:37] + "..."
            raise ExpressionError(f"number {shown} is not finite (too large for a float)")
        return Num(value, None)
    if not isinstance(text, str):
        raise ExpressionError(
            f"expected an expression string or a number, got {type(text).__name__} {text!r:.80}"
        )
    if len(text) > MAX_LENGTH:
        raise ExpressionError(
            f"expression is too long ({len(text)} characters, limit {MAX_LENGTH}): "
            f"{_quote(text[:40])}...",
            text=text,
        )
    if not text.strip():
        raise ExpressionError(f"empty expression {_quote(text)}", text=text)
    node = _Parser(text).parse()
    if _depth(node) > 2 * MAX_DEPTH:
        raise ExpressionError(
            f"expression is nested too deeply (tree depth limit {2 * MAX_DEPTH}) in "
            f"{_quote(text[:40])}...",
            text=text,
        )
    return node


# --------------------------------------------------------------------------- utilities


def walk(node: Node) -> Iterator[Node]:
    """Yield every node of the tree, parents before children (pre-order).

    Examples
    --------
    >>> [type(n).__name__ for n in walk(parse("sin(a) + 1"))]
    ['Binary', 'Call', 'Name', 'Num']
    """
    stack = [node]
    while stack:
        n = stack.pop()
        yield n
        stack.extend(reversed(_children(n)))


def names(node: Node) -> frozenset[str]:
    """The identifiers used by an expression (functions and ``pi`` excluded).

    Examples
    --------
    >>> sorted(names(parse("atan2(b*sin(t), a) + pi*r")))
    ['a', 'b', 'r', 't']
    """
    return frozenset(n.id for n in walk(node) if isinstance(n, Name))


# --------------------------------------------------------------------------- printing

_PREC_ADD, _PREC_MUL, _PREC_UNARY, _PREC_POW, _PREC_ATOM = 1, 2, 3, 4, 5


def _prec(node: Node) -> int:
    if isinstance(node, Binary):
        return _PREC_POW if node.op == "**" else _PREC_MUL if node.op in "*/" else _PREC_ADD
    if isinstance(node, Unary):
        return _PREC_UNARY
    if isinstance(node, Num) and (node.value < 0 or math.copysign(1.0, node.value) < 0):
        return _PREC_UNARY
    return _PREC_ATOM


def _num_text(value: float) -> str:
    if value.is_integer() and abs(value) < 1e16:
        return str(int(value))
    return repr(value)


def to_text(node: Node) -> str:
    """Print a tree as canonical text; ``parse(to_text(t)) == t``.

    Examples
    --------
    >>> to_text(parse("(a+b)*c - -x**2"))
    '(a + b) * c - -x ** 2'
    >>> to_text(parse("2 ** 3 ** 2"))
    '2 ** 3 ** 2'
    >>> to_text(parse("(2 ** 3) ** 2"))
    '(2 ** 3) ** 2'
    """

    def wrap(child: Node, needs: bool) -> str:
        s = to_text(child)
        return f"({s})" if needs else s

    if isinstance(node, Num):
        return _num_text(float(node.value)) + (node.unit or "")
    if isinstance(node, Name):
        return node.id
    if isinstance(node, Const):
        return node.name
    if isinstance(node, Call):
        return f"{node.func}({', '.join(to_text(a) for a in node.args)})"
    if isinstance(node, Unary):
        inner = wrap(node.operand, _prec(node.operand) < _PREC_UNARY)
        sep = " " if inner[:1] in "+-" else ""
        return f"{node.op}{sep}{inner}"
    if isinstance(node, Binary):
        p = _prec(node)
        if node.op == "**":
            left = wrap(node.left, _prec(node.left) < _PREC_ATOM)
            right = wrap(node.right, _prec(node.right) < _PREC_UNARY)
        else:
            left = wrap(node.left, _prec(node.left) < p)
            right = wrap(node.right, _prec(node.right) <= p)
        return f"{left} {node.op} {right}"
    raise TypeError(f"not an expression node: {node!r}")


# --------------------------------------------------------------------------- evaluation

_MATH = {
    "sin": math.sin,
    "cos": math.cos,
    "tan": math.tan,
    "asin": math.asin,
    "acos": math.acos,
    "atan": math.atan,
    "atan2": math.atan2,
    "sqrt": math.sqrt,
    "abs": abs,
}


def evaluate(node: Node | str | int | float, env: Mapping[str, float] | None = None, *,
             angle_unit_factor: float = 1.0) -> float:
    """Evaluate a tree numerically (pure Python tree walk).

    Parameters
    ----------
    node : Node (or text / number, parsed first)
    env : mapping of names to numbers
    angle_unit_factor : float
        Radians per unit of the result for angle literals: ``30deg`` evaluates to
        ``radians(30) / angle_unit_factor`` (1.0 -> radians, pi/180 -> degrees).
        Angular rate/acceleration/jerk literals (``10rpm``) become rad/s, rad/s², rad/s³.
        Length units cannot be evaluated here (the model's length unit is unknown).

    Raises
    ------
    ExpressionError
        Unknown name, length unit, domain error (``sqrt(-1)``), division by zero or a
        non-finite result.

    Examples
    --------
    >>> evaluate(parse("2**3**2"))
    512.0
    >>> round(evaluate(parse("theta + 90deg"), {"theta": 0.5}), 6)
    2.070796
    >>> round(evaluate("atan2(1, 1)", angle_unit_factor=1.0), 6)
    0.785398
    """
    if not isinstance(node, (Num, Name, Const, Unary, Binary, Call)):
        node = parse(node)
    env = {} if env is None else env
    text = None

    def fail(msg: str) -> ExpressionError:
        nonlocal text
        if text is None:
            try:
                text = to_text(node)
            except Exception:  # pragma: no cover - malformed hand-built tree
                text = repr(node)
        return ExpressionError(f"{msg} in {_quote(text)}", text=text)

    def ev(n: Node) -> float:
        if isinstance(n, Num):
            value = float(n.value)
            if n.unit is None:
                return value
            info = unit_info(n.unit)
            try:
                kind = unit_kind(n.unit)
            except UnitError:
                raise fail(f"unknown unit {n.unit!r}") from None
            factor = info.si_factor
            if kind is Kind.ANGLE:
                return value * factor / angle_unit_factor
            if kind.is_angular:
                return value * factor
            raise fail(
                f"cannot evaluate {to_text(n)!r} here: {kind.value} units are not "
                "converted in this field; give the number in the model's length unit"
            )
        if isinstance(n, Name):
            try:
                value = env[n.id]
            except KeyError:
                raise fail(f"unknown name {n.id!r}") from None
            try:
                return float(value)
            except (TypeError, ValueError):
                raise fail(f"name {n.id!r} has a non-numeric value {value!r}") from None
        if isinstance(n, Const):
            return CONSTANTS[n.name]
        if isinstance(n, Unary):
            v = ev(n.operand)
            return -v if n.op == "-" else v
        if isinstance(n, Binary):
            a = ev(n.left)
            b = ev(n.right)
            try:
                if n.op == "+":
                    return a + b
                if n.op == "-":
                    return a - b
                if n.op == "*":
                    return a * b
                if n.op == "/":
                    return a / b
                if n.op == "**":
                    return math.pow(a, b)
            except ZeroDivisionError:
                raise fail("division by zero") from None
            except OverflowError:
                raise fail(f"overflow in {to_text(n)!r}") from None
            except ValueError:
                raise fail(f"math domain error in {to_text(n)!r}") from None
            raise fail(f"unknown operator {n.op!r}")
        if isinstance(n, Call):
            fn = _MATH.get(n.func)
            if fn is None:
                raise fail(f"unknown function {n.func!r} (allowed: {_ALLOWED_FUNCS})")
            args = [ev(a) for a in n.args]
            try:
                return float(fn(*args))
            except (ValueError, OverflowError):
                raise fail(f"math domain error in {to_text(n)!r}") from None
            except TypeError:
                raise fail(f"{n.func}() takes exactly {FUNCTIONS[n.func]} argument(s)") from None
        raise fail(f"not an expression node: {n!r}")

    result = ev(node)
    if not math.isfinite(result):
        raise fail(f"expression evaluates to a non-finite value ({result})")
    return result
