"""The ``loopsolve view`` page as the tests open and read it: the sweep the command makes, opening a
page in the browser without console errors, and the page's number format written in Python."""

import math
from decimal import ROUND_HALF_UP, Decimal

from loopsolve.cli import _sweep_for, build_parser


def cli_sweep(path, *extra):
    """The sweep ``loopsolve view PATH --step 10 ...`` makes (default range, through limits if needed)."""
    return _sweep_for(build_parser().parse_args(["view", str(path), "--step", "10", "-q", "-o", "x.html", *extra]))


def open_page(driver, page_path):
    driver.get_log("browser")
    driver.get_log("performance")  # start both logs afresh
    driver.get(page_path.as_uri())
    errors = [e for e in driver.get_log("browser") if e["level"] in ("SEVERE", "WARNING")]
    assert not errors, errors
    assert driver.execute_script("return document.readyState") == "complete"


def js_fmt(v, digits=6) -> str:
    """view.js ``fmt(v, 6)``: toFixed to ``digits`` significant digits, trailing zeros cut;
    toExponential(digits − 2) for |v| ≥ 1e6 or < 1e-4; '–' for a missing value."""
    if v is None or not math.isfinite(v):
        return "–"
    if v == 0:
        return "0"
    a = abs(v)
    sign = "-" if v < 0 else ""
    if a >= 1e6 or a < 1e-4:
        f = digits - 2
        d = Decimal(a)
        e = d.adjusted()
        m = d.scaleb(-e).quantize(Decimal(1).scaleb(-f), ROUND_HALF_UP)
        if m >= 10:
            e += 1
            m = d.scaleb(-e).quantize(Decimal(1).scaleb(-f), ROUND_HALF_UP)
        return f"{sign}{m}e{'-' if e < 0 else ''}{abs(e)}"
    f = max(0, digits - 1 - math.floor(math.log10(a)))
    s = sign + str(Decimal(a).quantize(Decimal(1).scaleb(-f), ROUND_HALF_UP))
    return s.rstrip("0").rstrip(".") if "." in s else s
