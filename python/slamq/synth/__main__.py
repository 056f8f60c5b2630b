"""``python -m slamq.synth``: the synthetic damage study (see :mod:`slamq.synth.damage`)."""

import sys

from slamq.synth.damage import main

if __name__ == "__main__":
    sys.exit(main())
