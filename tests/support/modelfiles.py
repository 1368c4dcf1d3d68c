"""A good four-bar model file and the bad files made from it by small edits, with the errors they
must raise, and expressions that try to run code (the model and CLI tests share them)."""

from loopsolve.errors import ModelFileError


GOOD = """\
name = "four-bar"
units = { length = "mm", angle = "deg" }

[parameters]
r1 = 60
r2 = 25
r3 = 70
r4 = 45

[variables]
theta2 = { input = true, guess = 90 }
theta3 = { guess = 20 }
theta4 = { guess = 80 }

[vectors]
r1 = { length = "r1", angle = 0 }
r2 = { length = "r2", angle = "theta2" }
r3 = { length = "r3", angle = "theta3" }
r4 = { length = "r4", angle = "theta4" }

[[loops]]
equation = "r2 + r3 = r1 + r4"

[points]
C = "r2 + r3"
"""


def edit(*pairs: tuple[str, str]) -> str:
    """GOOD with each (old, new) replaced exactly once."""
    text = GOOD
    for old, new in pairs:
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    return text


#: (id, file text, error class, fragments every message must contain besides the file name)
BAD = [
    ("unknown-name", edit(('length = "r3"', 'length = "r33"')), ModelFileError,
     ["vectors.r3.length", "unknown name 'r33'"]),
    ("unknown-name-inside-sqrt", edit(('length = "r3"', 'length = "sqrt(r33**2)"')), ModelFileError,
     ["vectors.r3.length", "unknown name 'r33'"]),
    ("undeclared-vector-in-loop", edit(('"r2 + r3 = r1 + r4"', '"r2 + r3 = r1 + r5"')), ModelFileError,
     ["loops[0].equation", "undeclared vector 'r5'", "r2 + r3 = r1 + r5"]),
    ("undeclared-vector-in-point", edit(('C = "r2 + r3"', 'C = "r2 + r9"')), ModelFileError,
     ["points.C", "undeclared vector 'r9'"]),
    ("missing-key-angle", edit(('r3 = { length = "r3", angle = "theta3" }', 'r3 = { length = "r3" }')),
     ModelFileError, ["vectors.r3", "missing key", "angle"]),
    ("missing-loop-equation", edit(('equation = "r2 + r3 = r1 + r4"', 'name = "main"')), ModelFileError,
     ["loops[0]", "equation"]),
    ("missing-loops", edit(('[[loops]]\nequation = "r2 + r3 = r1 + r4"\n', '')), ModelFileError,
     ["loops", "no vector loops"]),
    ("wrong-type-parameter", edit(("r2 = 25", "r2 = [25]")), ModelFileError,
     ["parameters.r2", "[25]"]),
    ("wrong-type-guess", edit(("guess = 20", 'guess = "abc"')), ModelFileError,
     ["variables.theta3.guess", "abc"]),
    ("wrong-type-input-flag", edit(("input = true", 'input = "yes"')), ModelFileError,
     ["variables.theta2.input", "true or false", "'yes'"]),
    ("wrong-type-vector", edit(('r1 = { length = "r1", angle = 0 }', 'r1 = "r1"')), ModelFileError,
     ["vectors.r1", "length"]),
    ("wrong-type-loop-equation", edit(('equation = "r2 + r3 = r1 + r4"', "equation = 5")), ModelFileError,
     ["loops[0].equation", "expected a string", "5"]),
    ("loops-not-array", edit(("[[loops]]", "[loops]")), ModelFileError,
     ["loops", "array of tables"]),
    ("duplicate-toml-key", edit(("r2 = 25", "r2 = 25\nr2 = 26")), ModelFileError,
     ["malformed TOML", "line 7", "declared twice"]),
    ("parameter-and-variable", edit(("r4 = 45\n", "r4 = 45\ntheta3 = 5\n")), ModelFileError,
     ["variables.theta3", "both as a parameter and as a variable"]),
    ("more-unknowns-than-equations",
     edit(("theta4 = { guess = 80 }", "theta4 = { guess = 80 }\nphi = { guess = 1 }"),
          ('r1 = { length = "r1", angle = 0 }', 'r1 = { length = "r1", angle = "phi" }')),
     ModelFileError, ["variables", "3 unknown variable(s) (theta3, theta4, phi)", "2 scalar loop equations"]),
    ("fewer-unknowns-than-equations",
     edit(("theta3 = { guess = 20 }\n", ""), ('angle = "theta3"', "angle = 20")),
     ModelFileError, ["variables", "1 unknown variable(s) (theta4)", "2 scalar loop equations"]),
    ("no-input", edit(("input = true, ", "")), ModelFileError,
     ["variables", "no input", "input = true"]),
    ("two-inputs", edit(("theta3 = { guess = 20 }", "theta3 = { input = true, guess = 20 }")), ModelFileError,
     ["variables", "2 input(s) declared (theta2, theta3)", "mobility of 1"]),
    ("non-numeric-parameter", edit(("r2 = 25", 'r2 = "twenty-five"')), ModelFileError,
     ["parameters.r2", "'twenty-five' is not a number"]),
    ("parameter-wrong-unit", edit(("r2 = 25", 'r2 = "25deg"')), ModelFileError,
     ["parameters.r2", "25deg"]),
    ("infinite-parameter", edit(("r2 = 25", "r2 = inf")), ModelFileError,
     ["parameters.r2", "not finite"]),
    ("speed-wrong-unit", edit(("guess = 90 }", 'guess = 90, speed = "10mm/s" }')), ModelFileError,
     ["variables.theta2.speed", "10mm/s"]),
    ("speed-on-non-input", edit(("guess = 20 }", 'guess = 20, speed = "1rad/s" }')), ModelFileError,
     ["variables.theta3", "only for the input"]),
    ("unknown-top-level-key", GOOD.replace('units = {', 'colour = "red"\nunits = {'), ModelFileError,
     ["colour", "unknown key"]),
    ("unknown-vector-key", edit(('r1 = { length = "r1", angle = 0 }', 'r1 = { length = "r1", angle = 0, mass = 3 }')),
     ModelFileError, ["vectors.r1", "mass"]),
    ("bad-angle-unit", edit(('angle = "deg" }', 'angle = "grad" }')), ModelFileError,
     ["units", "grad"]),
    ("pi-in-degree-angle", edit(('r1 = { length = "r1", angle = 0 }', 'r1 = { length = "r1", angle = "pi" }')),
     ModelFileError, ["vectors.r1.angle", "pi degrees"]),
    ("angle-and-length-mixed", edit(('length = "r3"', 'length = "theta3"')), ModelFileError,
     ["theta3", "both as an angle and as a length"]),
    ("unknown-function", edit(('length = "r3"', 'length = "exp(r3)"')), ModelFileError,
     ["vectors.r3.length", "unknown function 'exp'"]),
    ("bad-loop-syntax", edit(('"r2 + r3 = r1 + r4"', '"r2 + r3 = r1 = r4"')), ModelFileError,
     ["loops[0].equation", "more than one '='"]),
    ("bad-variable-name", edit(("theta4 = { guess = 80 }", "theta4 = { guess = 80 }\n\"4x\" = { guess = 1 }")),
     ModelFileError, ["variables.4x", "not a valid name"]),
    ("reserved-name", edit(("r4 = 45\n", "r4 = 45\nsin = 3\n")), ModelFileError,
     ["parameters.sin", "reserved"]),
    ("bad-mode-signature", GOOD + '\n[modes]\nopen = "x"\n', ModelFileError,
     ["modes.open", "+ and -"]),
    ("huge-exponent", edit(('length = "r3"', 'length = "r3 + 0*(10**10**10)"')), ModelFileError,
     ["vectors.r3.length", "exponent", "too large"]),
    ("malformed-toml", edit(("[points]", "[points")), ModelFileError,
     ["malformed TOML", "line"]),
    ("not-toml-at-all", "this is not a model file\n", ModelFileError, ["malformed TOML"]),
]


#: code-injection attempts, each placed in an expression, a loop and a point; %s is a marker file
INJECTIONS = [
    "__import__('os').system('touch %s')",
    "().__class__.__bases__[0].__subclasses__()",
    "open('%s', 'w')",
    "exec(\"open('%s','w')\")",
    "eval('1')",
    "(lambda: __import__('os').system('touch %s'))()",
    "r3 if 1 else 2",
    "[r3][0]",
    "r3; import os",
    "os.system('touch %s')",
    "r3.real",
    "globals()",
    "r3 @ r3",
    "`touch %s`",
    "$(touch %s)",
]
