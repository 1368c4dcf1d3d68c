"""``python -m loopsolve``: the ``loopsolve`` command."""

import sys

from .cli import main

if __name__ == "__main__":  # not when imported (pytest --doctest-modules collects every module)
    sys.exit(main())
