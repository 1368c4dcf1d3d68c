"""Many designs at once: lockstep sweeps, studies, metrics, sensitivities; atlases (:mod:`.atlas`) and
synthesis (:mod:`.synthesis`: general, classical, shape).

See ARCHITECTURE.md for the layers and what lives where."""
