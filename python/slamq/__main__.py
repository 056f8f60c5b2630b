"""``python -m slamq ...`` is the ``slamq`` command."""

import sys

from slamq.cli import main

sys.exit(main())
