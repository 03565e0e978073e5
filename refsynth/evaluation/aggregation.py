"""Aggregation over seeds, and the paper's relative findings checked on the result (§3.3).

:func:`aggregate` turns the runner's one-result-per-case into one row per
scene × size × sampling × method: the mean MAR (Eq. 13) over the NP seeds and
its spread. :func:`findings` checks, on those rows, the paper's relative
findings (BP beats NP, edges help NP, priority order beats onion order,
isophotes help, error grows with the unknown fraction), with a tie when the
difference is within the spread over seeds.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3 (Tables 1–4, Figs. 7, 13, 16),
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["TIMING_FIELDS", "PAIRWISE_FINDINGS", "fsum_mean", "aggregate", "without_timing",
           "findings"]

#: Row fields that hold wall time: they differ between runs and are left
#: out of every identity check (:func:`without_timing`, ``--no-timing``).
TIMING_FIELDS = ("seconds",)


# ----------------------------------------------------------------------------- aggregation


def fsum_mean(values: Sequence[float]) -> float:
    """The mean, summed with :func:`math.fsum` (correctly rounded, whatever the order).

    Parameters
    ----------
    values : sequence of float
        At least one value.

    Returns
    -------
    float
        ``fsum(values) / len(values)``.

    Examples
    --------
    >>> fsum_mean([0.1] * 10), sum([0.1] * 10) / 10
    (0.1, 0.09999999999999999)
    """
    return float(math.fsum(values) / len(values))


def aggregate(runs: Sequence[dict]) -> list[dict]:
    """One row per scene × size × sampling × method: the mean and spread over seeds (§3.3).

    Parameters
    ----------
    runs : sequence of dict
        :func:`refsynth.evaluation.runner.run_case` results.

    Returns
    -------
    list of dict
        In order of first appearance. Fields: ``scene``, ``scene_spec``,
        ``size``, ``units``, ``sampling``, ``unknown_percent``, ``known``,
        ``evaluated``, ``method``, ``seeds`` (the list), ``mar`` (mean over
        seeds), ``mar_sd`` (sample standard deviation, ``None`` for one
        seed), ``mar_min``, ``mar_max``, ``mar_per_seed``, ``rmse``, ``bad1``,
        ``bad3`` (means) and ``seconds`` (mean wall time of the fill, the
        only field that differs between runs).

    Examples
    --------
    >>> runs = [dict(scene="s", scene_spec="s", size="8x8", units="m", sampling="x78",
    ...              unknown_percent=75.0, known=16, evaluated=48, method="np", seed=s,
    ...              mar=m, rmse=m, bad1=0.0, bad3=0.0, seconds=1.0)
    ...         for s, m in enumerate([1.0, 2.0, 3.0])]
    >>> row = aggregate(runs)[0]
    >>> row["mar"], row["mar_sd"], row["seeds"]
    (2.0, 1.0, [0, 1, 2])
    """
    groups: dict[tuple, list[dict]] = {}
    for run in runs:
        key = (run["scene_spec"], run["size"], run["sampling"], run["method"])
        groups.setdefault(key, []).append(run)
    rows = []
    for members in groups.values():
        members = sorted(members, key=lambda r: r["seed"])
        first = members[0]
        mars = [m["mar"] for m in members]
        rows.append(dict(
            scene=first["scene"],
            scene_spec=first["scene_spec"],
            size=first["size"],
            units=first["units"],
            sampling=first["sampling"],
            unknown_percent=first["unknown_percent"],
            known=first["known"],
            evaluated=first["evaluated"],
            method=first["method"],
            seeds=[m["seed"] for m in members],
            mar=fsum_mean(mars),
            mar_sd=float(np.std(mars, ddof=1)) if len(mars) > 1 else None,
            mar_min=min(mars),
            mar_max=max(mars),
            mar_per_seed=mars,
            rmse=fsum_mean([m["rmse"] for m in members]),
            bad1=fsum_mean([m["bad1"] for m in members]),
            bad3=fsum_mean([m["bad3"] for m in members]),
            seconds=fsum_mean([m["seconds"] for m in members]),
        ))
    return rows


def without_timing(rows: Sequence[dict]) -> list[dict]:
    """The rows without their :data:`TIMING_FIELDS`: what must be identical across runs.

    Parameters
    ----------
    rows : sequence of dict
        Results of :func:`refsynth.evaluation.runner.run_case` or :func:`aggregate`.

    Returns
    -------
    list of dict
        New dicts; ``rows`` is not changed.

    Examples
    --------
    >>> without_timing([{"method": "np", "mar": 0.2, "seconds": 1.5}])
    [{'method': 'np', 'mar': 0.2}]
    """
    return [{k: v for k, v in row.items() if k not in TIMING_FIELDS} for row in rows]


# ----------------------------------------------------------------------------- findings


#: The paper's relative findings, as (name, better method, worse method, source).
PAIRWISE_FINDINGS = (
    ("BP < NP", "bp", "np", "Tables 1–4"),
    ("Fig. 6's BP < NP", "bp-fig6", "np", "Tables 1–4"),
    ("BP on NP's fill < NP", "bp-obs-np", "np", "a departure; Tables 1–4"),
    ("NP < NP without edges", "np", "np-noedges", "Table 3, Fig. 13"),
    ("BP < NP without edges", "bp", "np-noedges", "Table 3, Fig. 13"),
    ("priority order < onion order", "np", "np-onion", "Fig. 7"),
    ("isophotes help: NP < NP without isophotes", "np", "np-noisophotes", "Fig. 16"),
)


def _spread(row: dict) -> float:
    return row["mar_sd"] or 0.0


def findings(rows: Sequence[dict]) -> list[dict]:
    """Check the paper's relative findings on aggregated rows.

    For each scene × sampling where both methods of a pairwise finding ran,
    the finding *holds* when the first method's mean MAR is lower; it is a
    *tie* when the difference is within the sum of the two standard
    deviations over seeds (a deterministic method has none). "Error grows
    with the unknown fraction" is checked per scene × method over the
    x-stripe samplings, which differ only in their fraction.

    Parameters
    ----------
    rows : sequence of dict
        Rows of :func:`aggregate` (``scene``, ``sampling``, ``method``,
        ``mar``, ``mar_sd`` are used).

    Returns
    -------
    list of dict
        ``finding``, ``source``, ``scene``, ``sampling``, ``better`` (the MAR
        of the method the paper finds better, or the sequence of MARs),
        ``worse`` and ``verdict`` (``"holds"``, ``"tie"`` or ``"fails"``).

    Examples
    --------
    >>> rows = [dict(scene="room", sampling="g5_25", unknown_percent=70.0, method=m, mar=e,
    ...              mar_sd=None) for m, e in [("np", 0.2), ("bp", 0.1)]]
    >>> [(f["finding"], f["better"], f["worse"], f["verdict"]) for f in findings(rows)]
    [('BP < NP', 0.1, 0.2, 'holds')]
    """
    index = {(r["scene"], r["sampling"], r["method"]): r for r in rows}
    out = []
    scenes_samplings = list(dict.fromkeys((r["scene"], r["sampling"]) for r in rows))
    for name, better, worse, source in PAIRWISE_FINDINGS:
        for scene, sampling in scenes_samplings:
            a, b = index.get((scene, sampling, better)), index.get((scene, sampling, worse))
            if a is None or b is None:
                continue
            difference = b["mar"] - a["mar"]
            if abs(difference) <= _spread(a) + _spread(b):
                verdict = "tie"
            else:
                verdict = "holds" if difference > 0 else "fails"
            out.append(dict(finding=name, source=source, scene=scene, sampling=sampling,
                            better=a["mar"], worse=b["mar"], verdict=verdict))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for method in methods:
            series = sorted(
                (r for r in rows if r["scene"] == scene and r["method"] == method
                 and r["sampling"].startswith("x")),
                key=lambda r: r["unknown_percent"],
            )
            if len(series) < 2:
                continue
            mars = [r["mar"] for r in series]
            grows = all(b > a for a, b in zip(mars, mars[1:]))
            out.append(dict(finding=f"error grows with the unknown fraction ({method})",
                            source="Tables 1, 4", scene=scene,
                            sampling=",".join(r["sampling"] for r in series),
                            better=mars, worse=None, verdict="holds" if grows else "fails"))
    return out

