"""The ``numba`` engine (``engine="numba"``): the tracer's regular steps compiled to machine code.

:mod:`.steps` (the step loop around the natural step that :mod:`loopsolve.kinematics.stepgen` generates for the
model's block structure, the same source the Python tracer runs) and :mod:`.jit` (the generated
kinematics, the generated step and the step loop compiled into one module per model structure,
cached on disk). Covered: every solve order of 1×1 and 2×2 diagonal blocks (four-bars,
slider-cranks, inverted slider-cranks, six-bars, the diagram models); a structure with a larger
block runs the Python tracer whatever the engine.
"""
