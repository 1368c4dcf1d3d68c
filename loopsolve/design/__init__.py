"""Many designs at once: lockstep sweeps, studies, metrics, sensitivities; atlases of coupler curves
(``design.atlas``) and synthesis (``design.synthesis``: general, classical, shape).

See ARCHITECTURE.md for the layers and what lives where."""
