"""``python -m loopsolve``: the ``loopsolve`` command."""

import sys

from .cli import main

sys.exit(main())
