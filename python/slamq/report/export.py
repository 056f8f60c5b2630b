"""The summary tables for papers and READMEs: Markdown (``tables.md``) and LaTeX
(``tables.tex``)."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd

from slamq.report.formatting import format_mean_std
from slamq.verdict.ranking import METRICS

__all__ = ["write_tables"]


def write_tables(summary: pd.DataFrame, out: Path) -> tuple[Path, Path]:
    """The per-sequence table of mean ± std as Markdown (``tables.md``) and LaTeX
    (``tables.tex``) for papers and READMEs.

    Examples
    --------
    >>> import tempfile, pathlib, pandas as pd
    >>> s = pd.DataFrame({"sequence": ["office"], "algorithm": ["gmapping"], "n": [3],
    ...                   "corners_mean": [12.0], "corners_std": [2.0], "corners_n": [3]}
    ...                  ).set_index(["sequence", "algorithm"])
    >>> md, tex = write_tables(s, pathlib.Path(tempfile.mkdtemp()))
    >>> print(md.read_text().splitlines()[2])
    | office | gmapping | 3 | – | – | 12 ± 2 | – |
    """
    # the ground-truth map's and the relations' columns only when some map had them
    metrics = [m for m in METRICS if not m.key.startswith(("gt_", "rel_"))
               or int(pd.to_numeric(summary.get(f"{m.key}_n", pd.Series(dtype=float)),
                                    errors="coerce").fillna(0).sum()) > 0]
    heads = [m.heading for m in metrics]
    md = ["| sequence | algorithm | runs | " + " | ".join(heads) + " |",
          "|---|---|---:|" + "---:|" * len(heads)]
    tex = [r"\begin{tabular}{ll r" + "r" * len(heads) + "}", r"\hline",
           "sequence & algorithm & runs & " + " & ".join(_tex(h) for h in heads) + r" \\",
           r"\hline"]
    for (seq, alg), row in summary.iterrows():
        cells = []
        for m in metrics:
            if f"{m.key}_mean" in row and int(row.get(f"{m.key}_n", 0) or 0) > 0:
                cells.append(format_mean_std(row[f"{m.key}_mean"], row[f"{m.key}_std"]))
            else:
                cells.append("–")
        n = int(row["n"])
        md.append(f"| {seq} | {alg} | {n} | " + " | ".join(cells) + " |")
        tex.append(f"{_tex(seq)} & {_tex(alg)} & {n} & "
                   + " & ".join(_tex(c).replace("±", r"$\pm$") for c in cells) + r" \\")
    tex += [r"\hline", r"\end{tabular}"]
    md_path, tex_path = out / "tables.md", out / "tables.tex"
    md_path.write_text("\n".join(md) + "\n", encoding="utf-8")
    tex_path.write_text("\n".join(tex) + "\n", encoding="utf-8")
    return md_path, tex_path


def _tex(text: str) -> str:
    """``text`` with LaTeX's special characters escaped (one pass, so that an escape is
    never escaped again).

    Examples
    --------
    >>> _tex("slam_toolbox {v2} 50% & more – \\\\")
    'slam\\\\_toolbox \\\\{v2\\\\} 50\\\\% \\\\& more -- \\\\textbackslash{}'
    """
    return re.sub(r"[\\&%$#_{}–]", lambda m: _TEX[m.group(0)], str(text))


_TEX = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
        "_": r"\_", "{": r"\{", "}": r"\}", "–": "--"}

