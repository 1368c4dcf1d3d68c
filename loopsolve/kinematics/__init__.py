"""Numbers from the compiled functions: Newton, modes, branch tracking, sweeps, results.

See ARCHITECTURE.md for the layers and what lives where."""
