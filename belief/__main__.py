"""``python -m belief``: the command line, as ``belief``."""

import sys

from belief.cli import main

if __name__ == "__main__":
    sys.exit(main())
