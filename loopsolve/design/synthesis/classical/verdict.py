"""The tracker's verdict on a four-bar that must pass through given configurations.

Shared by the classical synthesis methods (:mod:`loopsolve.design.synthesis.classical.freudenstein`,
:mod:`loopsolve.design.synthesis.classical.burmester`): a design from a closed form is only a candidate until the tracker
has moved it from one precision configuration to the next. The defect kinds are those of the
synthesis contract (``../shared/DESIGN.md``, "Synthesis"):

* ``circuit`` — two configurations lie on different circuits (no motion joins them without
  taking the linkage apart);
* ``branch`` — same circuit, but the motion between them passes a limit (toggle) position,
  where the input would have to turn back;
* ``order`` — the input reaches them in another order than the one given;
* ``range`` — part of the intended input range cannot be reached (function generation).

For a Grashof four-bar (S + L < P + Q) the two joints of the link opposite the shortest link
never fold flat, so the sign of the angle at one of them is constant on a circuit and tells
the two circuits apart; a non-Grashof four-bar has one circuit.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ....kinematics.classic import GrashofClass, grashof

__all__ = ["Defect", "circuit_sign", "track_between"]


@dataclass(frozen=True, slots=True)
class Defect:
    """A reason a candidate linkage does not do its job.

    ``kind`` is ``"circuit"``, ``"branch"``, ``"order"``, ``"range"`` or ``"assembly"``;
    ``input`` the input value (model units) where it shows, when there is one.
    """

    kind: str
    message: str
    input: float | None = None

    def to_dict(self) -> dict:
        return {"kind": self.kind, "message": self.message, "input": self.input}


def circuit_sign(lengths, angles) -> int:
    """Which circuit a four-bar configuration lies on: +1 or −1 (0 for a non-Grashof linkage).

    Parameters
    ----------
    lengths : (r1, r2, r3, r4)
        Ground, input, coupler, output lengths (positive).
    angles : (t1, t2, t3, t4)
        Absolute directions (radians) of the loop vectors ``r2 + r3 = r1 + r4``.

    Examples
    --------
    >>> from loopsolve.design.synthesis.classical.verdict import circuit_sign
    >>> import math
    >>> circuit_sign((60, 25, 70, 45), (0, math.pi / 2, 0.28, 1.41))
    1
    """
    cls = grashof(*lengths)
    if cls in (GrashofClass.TRIPLE_ROCKER, GrashofClass.CHANGE_POINT):
        return 0
    t1, t2, t3, t4 = angles
    shortest = int(np.argmin(lengths))
    # the angle at a joint of the link opposite the shortest: r2 <-> r4, r1 <-> r3
    if shortest in (1, 0):  # opposite r4 or r3: the coupler-output joint C
        s = math.sin(t4 - t3)
    elif shortest == 3:  # opposite r2: the input-coupler joint B
        s = math.sin(t3 - t2)
    else:  # shortest coupler, opposite the ground: the input pivot
        s = math.sin(t2 - t1)
    return 1 if s > 0 else -1


def track_between(mech, z_from, x_to_deg: float, *, direction: int, steps: int = 24):
    """Track from configuration ``z_from`` to input ``x_to_deg`` moving the input one way.

    Returns ``(state_z, limit)``: the internal configuration reached at ``x_to_deg`` (or None)
    and the located input (display units) of a limit position met on the way (or None).
    """
    ck = mech.compile()
    ix = ck.input_idx[0]
    x0 = math.degrees(float(z_from[ix]))
    delta = x_to_deg - x0
    if direction * delta <= 0:
        delta += direction * 360.0 * math.ceil(-direction * delta / 360.0 + 1e-12)
    if abs(delta) < 1e-12:
        return np.asarray(z_from, dtype=float), None
    n = max(2, int(math.ceil(abs(delta) / 2.0)), steps if abs(delta) > 20 else 2)
    guess = {name: float(z_from[i]) for i, name in enumerate(ck.variables) if i != ix}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sw = mech.sweep(x0, x0 + delta, abs(delta) / n, guess=guess, mode=ck.signature(z_from), progress=False,
                        method="tracked", derivatives=1)
    limit = next((e.input for e in sw.events if e.kind.value == "limit"), None)
    if limit is not None or len(sw) < n + 1:
        return None, limit
    z = np.array([math.radians(float(sw[v][-1])) if ck.kinds[i].name == "ANGLE" else float(sw[v][-1])
                  for i, v in enumerate(ck.variables)])
    return z, None
