"""What several test files share, one module per concept (test files import nothing from one another).

``models``      the shared mechanisms and model texts, with their closed-form references
``pages``       the ``loopsolve view`` page: the command's sweep, opening it in Chromium, its number format
``latex``       reading the PDFs back; skipping (or failing, in CI) without TeX
``cli``         running ``loopsolve`` in a subprocess; its one-line errors
``synthesis``   synthesis references: log10 targets, Freudenstein constants, traced coupler curves
``modelfiles``  a good four-bar model file, bad files made from it, code-injection attempts
``probe``       the cache-key probe four-bar (model text with any field changed) and its closures
``editor``      a ``loopsolve edit`` server process and an HTTP client
``moved``       shipped models translated and rotated
"""
