"""``python -m loopsolve.cli``: the ``loopsolve`` command."""

import sys

from . import main

if __name__ == "__main__":
    sys.exit(main())
