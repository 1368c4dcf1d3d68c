"""Classical four-bar synthesis: Freudenstein's function generation and Burmester's motion generation.

:mod:`.freudenstein` and :mod:`.burmester` (the closed forms, checked by the tracker: :mod:`.verdict`),
:mod:`.burmester_search` (candidates for three to five poses, screened and ranked), :mod:`.transplant`
(a classical design written into the user's own model), :mod:`.motion` and :mod:`.run` (``synthesize
--method freudenstein|burmester``).
"""
