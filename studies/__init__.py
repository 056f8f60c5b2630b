"""Not a package to install: the studies run as ``python studies/NAME.py`` (README.md).
This file only gives the studies' tests unique module names under pytest."""
