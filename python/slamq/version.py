"""slamq's version, the one place it is written in Python (``slamq.__version__``; equal to
pyproject.toml's and Cargo.toml's, a test checks it).

>>> from slamq.version import __version__
>>> __version__.count(".")
2
"""

from __future__ import annotations

__version__ = "0.1.0"
