"""``python -m sphkit``: the ``sphkit`` command."""

import sys

from sphkit.cli import main

if __name__ == "__main__":
    sys.exit(main())
