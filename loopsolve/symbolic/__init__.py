"""Symbolic derivation (sympy), the generated numeric code and its cache, the TeX printer.

See ARCHITECTURE.md for the layers and what lives where."""
