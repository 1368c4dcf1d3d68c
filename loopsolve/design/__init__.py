"""Many designs at once: lockstep sweeps, studies, metrics, sensitivities, synthesis.

See ARCHITECTURE.md for the layers and what lives where."""
