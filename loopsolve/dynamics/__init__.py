"""Forces, the equation of motion and simulation of one-degree-of-freedom mechanisms.

See ARCHITECTURE.md for the layers and what lives where."""
