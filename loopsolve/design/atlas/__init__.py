"""Atlases of coupler curves: many designs of one model traced, labelled and described, stored in zarr.

:mod:`.descriptors` (curve descriptors free of placement and scale), :mod:`.frame` (which parameters place
a model), :mod:`.trace` (one chunk traced and labelled), :mod:`.store` (the zarr store, opened only when
trusted), :mod:`.build` (build, grow, open: :class:`Atlas`), :mod:`.defaults` (default atlases in the cache).
"""


def __getattr__(name):
    """``loopsolve.design.atlas`` was the module now at ``loopsolve.design.atlas.build``: its names answer
    here too, with a DeprecationWarning naming the new path (:mod:`loopsolve._moved`)."""
    from ..._moved import old_name

    return old_name(__name__, name)
