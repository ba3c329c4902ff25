"""``python -m simbridge``: the same command line as the ``simbridge`` script."""

import sys

from simbridge.cli import main

if __name__ == "__main__":
    sys.exit(main())
