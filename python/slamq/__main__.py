"""``python -m slamq ...`` is the ``slamq`` command."""

import sys

from slamq.cli import main

if __name__ == "__main__":
    sys.exit(main())
