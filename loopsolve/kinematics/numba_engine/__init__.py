"""The ``numba`` engine (``engine="numba"``): the tracer's regular steps compiled to machine code.

:mod:`.steps` (the step loop, a numba template of the Python tracer's natural steps) and :mod:`.jit`
(the generated kinematics and the step loop compiled into one module, cached on disk).
"""
