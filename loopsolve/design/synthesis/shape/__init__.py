"""Shape synthesis: linkages whose point traces a drawn curve, started from an atlas.

:mod:`.retrieval` (the atlas entries nearest a target curve, placed as starts), :mod:`.run`
(``synthesize(..., shape=...)``: retrieve, polish, certify; :class:`ShapeResult`), :mod:`.path_starts`
(atlas starts of free-timing path problems of the general method).
"""
