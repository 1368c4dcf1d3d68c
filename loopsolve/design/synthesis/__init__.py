"""Dimensional synthesis: parameter values that make a declared model do a given job, and their certificates.

The general method: :mod:`.problem` (the problem, its batched objective, the global search and the polish),
:mod:`.candidates` (many candidate designs evaluated at once), :mod:`.lockstep_lm` (many starts polished
together), :mod:`.requirements` (crank, transmission), :mod:`.limits` (the bounds checked before any work),
:mod:`.targets` (the targets file), :mod:`.run` (``synthesize``: runs, report, :class:`SynthesisResult`).
Shared by every method: :mod:`.design_model` (a found design as a model), :mod:`.certificate`,
:mod:`.structural_error`, :mod:`.report`. The classical methods are in :mod:`.classical`, shape synthesis
from an atlas in :mod:`.shape`.
"""


def __getattr__(name):
    """``loopsolve.design.synthesis`` was the module now at ``loopsolve.design.synthesis.problem``: its names
    answer here too, with a DeprecationWarning naming the new path (:mod:`loopsolve._moved`)."""
    from ..._moved import old_name

    return old_name(__name__, name)
