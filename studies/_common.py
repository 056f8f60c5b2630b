"""What the studies share: where the repository and the real-map corpus are, and how a
study's tables replace their section of a Markdown file (``--markdown``).

The studies run as ``python studies/NAME.py`` (this folder is then first on ``sys.path``);
studies/tests/conftest.py puts it there for the tests.
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

#: The repository's root (the folder holding studies/, python/, docs/).
REPO = Path(__file__).resolve().parents[1]
#: The real-map corpus: ../shared/data beside the clone; SLAMQ_SHARED_DATA overrides (as
#: for the tests).
SHARED_DATA = Path(os.environ.get("SLAMQ_SHARED_DATA", REPO.parent / "shared" / "data"))
#: Its maps folder, the default of the studies' ``--real``.
SHARED_MAPS = SHARED_DATA / "maps"


def print_or_write_section(text: str, path: Path | None, begin: str, end: str) -> int:
    r"""Print ``text``, or put it into the Markdown file ``path`` between the markers
    ``begin`` and ``end`` (the studies' ``--markdown``); returns the exit code (2 when the
    file has no such section).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "doc.md"
    >>> _ = p.write_text("# Doc\n<!-- a -->\nold\n<!-- b -->\ntail\n")
    >>> print_or_write_section("new\n", p, "<!-- a -->", "<!-- b -->"), p.read_text()
    (0, '# Doc\n<!-- a -->\nnew\n<!-- b -->\ntail\n')
    """
    if path is None:
        sys.stdout.write(text)
        return 0
    doc = path.read_text(encoding="utf-8")
    pattern = re.compile(re.escape(begin) + ".*?" + re.escape(end), re.S)
    if not pattern.search(doc):
        print(f"{path}: no {begin} ... {end} section", file=sys.stderr)
        return 2
    path.write_text(pattern.sub(lambda _: f"{begin}\n{text}{end}", doc), encoding="utf-8")
    return 0
