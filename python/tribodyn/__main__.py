"""``python -m tribodyn``: the same as the ``tribodyn`` command."""

import sys

from .app.cli import main

if __name__ == "__main__":
    sys.exit(main())
