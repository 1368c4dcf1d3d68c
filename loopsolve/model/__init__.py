"""The declaration of a mechanism: model files, expressions, units, topology, diagrams, bodies.

See ARCHITECTURE.md for the layers and what lives where."""
