"""The verdict on every sequence of a results table at once, with what the report shows
beside it: the summary per (sequence, algorithm), the evidence of the sequences judged
without ground truth, each sequence's verdict (the rule of docs/spec.md section 9) and its
ranking."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import pandas as pd

from slamq.verdict.evidence import sequence_evidence
from slamq.verdict.ranking import SequenceRanking, rank_sequence, summarize
from slamq.verdict.rule import needs_evidence, sequence_verdict

__all__ = ["Judgement", "judge"]


@dataclass
class Judgement:
    """The verdicts on a results table and what they rest on.

    Attributes
    ----------
    summary : pandas.DataFrame
        :func:`slamq.verdict.ranking.summarize` of the records, with ``agreement_mean``,
        ``_std`` and ``_n`` where a sequence was judged by the maps' agreement, and
        ``scan_crossing_mean``, ``_std``, ``_n`` where maps were scored against their own
        scans, and ``scan_split_*`` where their paths were (split in time).
    sequences : list of str
        The sequences, sorted.
    evidence : dict
        ``evidence[sequence]``: :func:`slamq.verdict.evidence.sequence_evidence`, for the
        sequences judged without ground truth.
    verdicts : list of dict
        One :func:`slamq.verdict.rule.sequence_verdict` per sequence, in ``sequences``'
        order.
    rankings : dict
        ``rankings[sequence]``: its :class:`~slamq.verdict.ranking.SequenceRanking`.
    """

    summary: pd.DataFrame
    sequences: list[str]
    evidence: dict[str, dict[str, Any]]
    verdicts: list[dict[str, Any]]
    rankings: dict[str, SequenceRanking]

    @property
    def by_sequence(self) -> dict[str, dict[str, Any]]:
        """The verdicts keyed by sequence."""
        return {v["sequence"]: v for v in self.verdicts}


def judge(ok: pd.DataFrame) -> Judgement:
    """Judge every sequence of successful records (loading their maps where the verdict
    rests on their agreement).

    Parameters
    ----------
    ok : pandas.DataFrame
        Successful records with ``sequence``, ``algorithm``, ``run``, ``map`` and the metric
        columns (:func:`slamq.verdict.records.load_results`, without the failed rows).

    Returns
    -------
    Judgement

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b"], "run": 0,
    ...                    "ate_rmse": [0.1, 0.3], "corners": [5, 9]})
    >>> j = judge(df)
    >>> j.verdicts[0]["best"], j.rankings["s"].order
    ('a', ['a', 'b'])
    """
    summary = summarize(ok)
    sequences = sorted(ok["sequence"].unique()) if len(ok) else []
    evidence = {s: sequence_evidence(ok, s) for s in sequences if needs_evidence(summary, s)}
    verdicts = [sequence_verdict(summary, s, evidence.get(s)) for s in sequences]
    _add_agreement(summary, evidence)
    by_sequence = {v["sequence"]: v for v in verdicts}
    rankings = {s: rank_sequence(summary, s, by_sequence[s]) for s in sequences}
    return Judgement(summary, sequences, evidence, verdicts, rankings)


def _add_agreement(summary: pd.DataFrame, evidence: dict[str, dict[str, Any]]) -> None:
    """The agreement figure of each algorithm as a summary column (``agreement_mean``,
    ``_std``, ``_n``), and its crossing share against its own scans
    (``scan_crossing_*``) and its path's split share (``scan_split_*``), so that the table
    shows what the verdict rested on."""
    if not evidence or not len(summary):
        return
    for key, field, runs in (("agreement", "support", "runs"),
                             ("scan_crossing", "scan_crossing", "scan_runs"),
                             ("scan_split", "scan_split", "split_runs")):
        values = [(seq, alg, e.get(field, math.nan), e.get(runs, 0))
                  for seq, ev in evidence.items() for alg, e in ev["algorithms"].items()]
        values = [v for v in values if (v[0], v[1]) in summary.index and math.isfinite(v[2])]
        if key != "agreement" and not values:
            continue
        summary[f"{key}_mean"] = math.nan
        summary[f"{key}_std"] = math.nan
        summary[f"{key}_n"] = 0
        for seq, alg, v, n in values:
            summary.loc[(seq, alg), [f"{key}_mean", f"{key}_n"]] = (v, n)
