"""What people look at: plots, drawings and their geometry, the HTML page, CAD, LaTeX documents.

See ARCHITECTURE.md for the layers and what lives where."""
