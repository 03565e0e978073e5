"""The results as Markdown: tables, pivots, run times, findings, and the paper beside ours (§3.3).

Every function takes the rows of :func:`refsynth.evaluation.aggregation.aggregate`
(or the checks of :func:`~refsynth.evaluation.aggregation.findings`) and returns
Markdown text; MAR (Eq. 13) is shown as the mean ± the sample standard
deviation over seeds. :data:`PAPER` holds the paper's own MARs (Tables 1–4,
Fig. 16), which :func:`format_paper_comparison` sets beside our analogues.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3 (Tables 1–4, Figs. 7, 11, 13, 16,
17), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence

from refsynth.evaluation.aggregation import fsum_mean
from refsynth.evaluation.baselines import BASELINES
from refsynth.evaluation.cases import SYNTHESIS_METHODS

__all__ = [
    "PAPER",
    "format_results",
    "format_pivot",
    "format_runtimes",
    "format_findings",
    "format_winners",
    "format_paper_comparison",
]


def _fmt_mar(row: dict) -> str:
    text = f"{row['mar']:.3f}"
    if row["mar_sd"] is not None:
        text += f" ± {row['mar_sd']:.3f}"
    return text


def _table(header: Sequence[str], body: Iterable[Sequence[str]]) -> list[str]:
    """The lines of a Markdown table: the header, the rule, then one line per row of cells."""
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header),
            *("| " + " | ".join(cells) + " |" for cells in body)]


def _titled(title: str, header: Sequence[str], body: Iterable[Sequence[str]]) -> str:
    """A title line, a blank line, then the table."""
    return "\n".join([title, "", *_table(header, body)])


def _by_scene(rows: Sequence[dict]) -> Iterator[tuple[str, list[dict]]]:
    """Each scene, in order of first appearance, with its rows."""
    for scene in dict.fromkeys(r["scene"] for r in rows):
        yield scene, [r for r in rows if r["scene"] == scene]


def format_results(rows: Sequence[dict], *, timing: bool = True) -> str:
    """Markdown tables, one per scene, of the aggregated rows (MAR: Eq. 13, §3.3.1).

    Columns: sampling, unknown %, method, seeds, MAR (mean ± sd over seeds),
    RMSE, bad > 1 and bad > 3 (% of the evaluated pixels, in the scene's
    units), and, with ``timing``, the mean wall time of one fill.

    Parameters
    ----------
    rows : sequence of dict
        Aggregated rows (:func:`refsynth.evaluation.aggregation.aggregate`).
    timing : bool, default True
        Add the ``seconds`` column (which differs between runs).

    Returns
    -------
    str
        The tables, separated by blank lines.

    Examples
    --------
    >>> row = dict(scene="room", size="16x16", units="m", sampling="x78", unknown_percent=75.0,
    ...            seeds=[0], mar_sd=None, bad1=0.0, bad3=0.01, seconds=0.5)
    >>> rows = [dict(row, method=m, mar=e, rmse=e)
    ...         for m, e in [("np", 0.2), ("bp", 0.1), ("nearest", 0.3)]]
    >>> print(format_results(rows, timing=False))
    ### room (m)
    <BLANKLINE>
    | sampling | unknown | method | seeds | MAR (m) | RMSE | bad>1 | bad>3 |
    |---|---|---|---|---|---|---|---|
    | x78 | 75.0 % | np | 1 | 0.200 | 0.200 | 0.0 % | 1.0 % |
    | x78 | 75.0 % | bp | 1 | 0.100 | 0.100 | 0.0 % | 1.0 % |
    | x78 | 75.0 % | nearest | 1 | 0.300 | 0.300 | 0.0 % | 1.0 % |
    """
    blocks = []
    for scene, members in _by_scene(rows):
        units = members[0]["units"]
        header = ["sampling", "unknown", "method", "seeds", f"MAR ({units})", "RMSE",
                  "bad>1", "bad>3"] + (["seconds"] if timing else [])
        body = [[r["sampling"], f"{r['unknown_percent']:.1f} %", r["method"],
                 str(len(r["seeds"])), _fmt_mar(r), f"{r['rmse']:.3f}",
                 f"{100 * r['bad1']:.1f} %", f"{100 * r['bad3']:.1f} %"]
                + ([f"{r['seconds']:.2f}"] if timing else []) for r in members]
        blocks.append(_titled(f"### {scene} ({units})", header, body))
    return "\n\n".join(blocks)


def format_pivot(rows: Sequence[dict]) -> str:
    """Markdown: one table per scene, a row per sampling, a column per method (mean MAR ± sd
    over seeds), in the scene's units.

    Parameters
    ----------
    rows : sequence of dict
        Rows of :func:`~refsynth.evaluation.aggregation.aggregate`, one per scene ×
        sampling × method; their ``mar`` and ``mar_sd`` fill the cells.

    Returns
    -------
    str
        The tables; ``–`` where a method did not run on a sampling.

    Examples
    --------
    >>> rows = [dict(scene="room", units="m", sampling=s, unknown_percent=u, method=m, mar=e,
    ...              mar_sd=None)
    ...         for s, u, m, e in [("x78", 75.0, "np", 0.2), ("x78", 75.0, "bp", 0.1),
    ...                            ("x63", 60.0, "np", 0.3)]]
    >>> print(format_pivot(rows))
    MAR, room (m)
    <BLANKLINE>
    | sampling | unknown | np | bp |
    |---|---|---|---|
    | x78 | 75.0 % | 0.200 | 0.100 |
    | x63 | 60.0 % | 0.300 | – |
    """
    blocks = []
    for scene, members in _by_scene(rows):
        methods = list(dict.fromkeys(r["method"] for r in members))
        index = {(r["sampling"], r["method"]): r for r in members}
        body = []
        for sampling in dict.fromkeys(r["sampling"] for r in members):
            first = next(r for r in members if r["sampling"] == sampling)
            body.append([sampling, f"{first['unknown_percent']:.1f} %"]
                        + [_fmt_mar(index[sampling, m]) if (sampling, m) in index else "–"
                           for m in methods])
        blocks.append(_titled(f"MAR, {scene} ({members[0]['units']})",
                              ["sampling", "unknown", *methods], body))
    return "\n\n".join(blocks)


def format_runtimes(rows: Sequence[dict]) -> str:
    """Markdown: mean wall time of one fill per scene size × method (over samplings and
    seeds), from the rows' ``seconds``.

    Parameters
    ----------
    rows : sequence of dict
        Rows of :func:`~refsynth.evaluation.aggregation.aggregate`; each row's
        ``seconds`` counts once per seed, a row without ``seconds`` not at all.

    Returns
    -------
    str
        The table, or ``""`` if no row has ``seconds``.

    Examples
    --------
    >>> rows = [dict(size="16x16", method="np", seconds=0.5, seeds=[0, 1]),
    ...         dict(size="32x32", method="np", seconds=2.0, seeds=[0]),
    ...         dict(size="16x16", method="bp", seconds=0.25, seeds=[0])]
    >>> print(format_runtimes(rows))
    | method | 16x16 | 32x32 |
    |---|---|---|
    | np | 0.50 s | 2.00 s |
    | bp | 0.25 s | – |
    """
    timed = [r for r in rows if r.get("seconds") is not None]
    if not timed:
        return ""
    sizes = list(dict.fromkeys(r["size"] for r in timed))
    body = []
    for method in dict.fromkeys(r["method"] for r in timed):
        cells = [method]
        for size in sizes:
            runs = [(r["seconds"], len(r["seeds"])) for r in timed
                    if r["method"] == method and r["size"] == size]
            total = sum(n for _, n in runs)
            cells.append(f"{sum(t * n for t, n in runs) / total:.2f} s" if total else "–")
        body.append(cells)
    return "\n".join(_table(["method", *sizes], body))


def _finding_group(item: dict) -> str:
    """The finding's name without the method of a growth check."""
    return item["finding"].split(" (")[0] if item["worse"] is None else item["finding"]


def format_findings(items: Sequence[dict], *, detail: bool = True) -> str:
    """Markdown: a summary (finding × scene: holds / ties / fails), then, with ``detail``,
    one line per check.

    Parameters
    ----------
    items : sequence of dict
        The checks of :func:`refsynth.evaluation.aggregation.findings`.
    detail : bool, default True
        Add the table of every check after the summary.

    Returns
    -------
    str
        The tables, or a sentence saying no finding could be checked.

    Examples
    --------
    >>> items = [dict(finding="BP < NP", source="Tables 1–4", scene="room", sampling="x78",
    ...               better=0.1, worse=0.2, verdict="holds")]
    >>> print(format_findings(items, detail=False).splitlines()[-1])
    | BP < NP (Tables 1–4) | 1 / 0 / 0 | 1 / 0 / 0 |
    """
    if not items:
        return "(no finding can be checked: the grid lacks the methods to compare)"
    scenes = list(dict.fromkeys(f["scene"] for f in items))
    groups = list(dict.fromkeys(_finding_group(f) for f in items))
    sources = {_finding_group(f): f["source"] for f in items}

    def counts(members: list[dict]) -> str:
        if not members:
            return "–"
        verdicts = [m["verdict"] for m in members]
        return " / ".join(str(verdicts.count(v)) for v in ("holds", "tie", "fails"))

    summary = []
    for group in groups:
        members = [f for f in items if _finding_group(f) == group]
        summary.append([f"{group} ({sources[group]})",
                        *(counts([m for m in members if m["scene"] == scene]) for scene in scenes),
                        counts(members)])
    lines = ["Each cell: holds / ties / fails (a tie: the difference is within the sum of the "
             "two standard deviations over seeds).", "",
             *_table(["finding (paper)", *scenes, "all"], summary)]
    if detail:
        checks = []
        for f in items:
            if f["worse"] is None:
                mar = " → ".join(f"{m:.3f}" for m in f["better"])
            else:
                mar = f"{f['better']:.3f} vs {f['worse']:.3f}"
            checks.append([f"{f['finding']} ({f['source']})", f["scene"], f["sampling"], mar,
                           f["verdict"]])
        lines += ["", *_table(["finding (paper)", "scene", "sampling", "MAR (first vs second)",
                               "verdict"], checks)]
    return "\n".join(lines)


def _best(group: Sequence[dict]) -> str:
    row = min(group, key=lambda r: r["mar"])
    return f"{row['method']} {_fmt_mar(row)}"


def format_winners(rows: Sequence[dict]) -> str:
    """Markdown: per scene × sampling, the best method by mean MAR, NP and BP with the
    paper's defaults, the best of refsynth's variants, the best baseline and the nearest
    fill — where refsynth wins and where it loses.

    Parameters
    ----------
    rows : sequence of dict
        Rows of :func:`~refsynth.evaluation.aggregation.aggregate`, compared by
        ``mar`` within each scene × sampling.

    Returns
    -------
    str
        The table (the scene × samplings where a refsynth variant and a
        baseline both ran), or ``""``.

    Examples
    --------
    >>> rows = [dict(scene="room", sampling="x78", method=m, mar=e, mar_sd=None)
    ...         for m, e in [("np", 0.2), ("bp", 0.1), ("nearest", 0.3), ("linear", 0.25)]]
    >>> print(format_winners(rows))
    | scene | sampling | best | np | bp | best refsynth variant | best baseline | nearest |
    |---|---|---|---|---|---|---|---|
    | room | x78 | bp 0.100 | 0.200 | 0.100 | bp 0.100 | linear 0.250 | 0.300 |
    """
    body = []
    for scene, sampling in dict.fromkeys((r["scene"], r["sampling"]) for r in rows):
        members = {r["method"]: r for r in rows
                   if r["scene"] == scene and r["sampling"] == sampling}
        ours = [r for m, r in members.items() if m in SYNTHESIS_METHODS]
        theirs = [r for m, r in members.items() if m in BASELINES]
        if not ours or not theirs:
            continue
        np_mar, bp_mar, nearest_mar = (_fmt_mar(members[m]) if m in members else "–"
                                       for m in ("np", "bp", "nearest"))
        body.append([scene, sampling, _best(list(members.values())), np_mar, bp_mar,
                     _best(ours), _best(theirs), nearest_mar])
    header = ["scene", "sampling", "best", "np", "bp", "best refsynth variant", "best baseline",
              "nearest"]
    return "\n".join(_table(header, body)) if body else ""


#: The paper's MARs (cm for USF, the units of its range images for
#: Middlebury), as read in shared/paper/EQUATIONS.md: table → row → method → MAR.
PAPER: dict[str, dict[str, dict[str, float]]] = {
    "Table 1 (USF 128×128, cm)": {
        "g24_80": {"np": 36.36, "bp": 4.23}, "g10_20": {"np": 5.76, "bp": 1.33},
        "g5_25": {"np": 8.86, "bp": 1.85}, "g3_28": {"np": 9.99, "bp": 2.76},
    },
    "Table 2 (USF 128×128, mean of 32 images at 61 %, cm)": {"mean": {"np": 4.27, "bp": 2.65}},
    "Table 3 (USF 128×128, 61 %, cm)": {
        "image 1": {"np-noedges": 8.58, "np": 3.77, "bp": 2.58},
        "image 2": {"np-noedges": 13.48, "np": 3.03, "bp": 1.63},
        "image 3": {"np-noedges": 11.39, "np": 2.99, "bp": 2.03},
        "image 4": {"np-noedges": 7.12, "np": 2.20, "bp": 1.36},
    },
    "Table 4 (Middlebury 450×375)": {
        "x63": {"np": 6.42, "bp": 3.90}, "x78": {"np": 6.45, "bp": 3.90},
        "x85": {"np": 7.98, "bp": 4.80},
    },
    "Fig. 16 (Middlebury, 65 % / 62 %)": {
        "65 %": {"np-noisophotes": 10.5, "np": 6.5}, "62 %": {"np-noisophotes": 12.2, "np": 7.3},
    },
}


def _ratio(a: float, b: float) -> str:
    return f"{a / b:.2f}" if b else "–"


def format_paper_comparison(rows: Sequence[dict]) -> str:
    """The paper's Tables 1, 3, 4 and Fig. 16 beside our analogues, where the grid has them.

    Table 1 ↔ the synthetic room 128×128 on the grid samplings; Table 3 ↔
    the rooms at g5_25 (no edges / NP / BP); Table 4 ↔ the Motorcycle
    450×375 on x-stripes; Fig. 16 ↔ the Motorcycle 450×375 at x63 (no
    isophotes / NP). The paper's scenes and units differ from ours, so
    compare the orderings, not the numbers.

    Parameters
    ----------
    rows : sequence of dict
        Rows of :func:`~refsynth.evaluation.aggregation.aggregate`; only those of
        the scenes, sizes and samplings above are read.

    Returns
    -------
    str
        The tables the rows have analogues for, or ``""``.

    Examples
    --------
    >>> row = dict(scene="synthetic-room-0", size="128x128", units="m", sampling="g5_25",
    ...            unknown_percent=70.0, seeds=[0], mar_sd=None)
    >>> rows = [dict(row, method="np", mar=0.4), dict(row, method="bp", mar=0.2)]
    >>> print(format_paper_comparison(rows).splitlines()[0])
    Table 1 analogue: synthetic room 0, 128×128 (m) — paper: USF images (cm)
    """
    index = {(r["scene"], r["sampling"], r["method"]): r for r in rows}

    def ours(scene: str, sampling: str, method: str) -> str:
        row = index.get((scene, sampling, method))
        return _fmt_mar(row) if row else "–"

    def ours_ratio(scene: str, sampling: str) -> str:
        bp, np_row = index.get((scene, sampling, "bp")), index.get((scene, sampling, "np"))
        return _ratio(bp["mar"], np_row["mar"]) if bp and np_row else "–"

    blocks = []
    table1 = PAPER["Table 1 (USF 128×128, cm)"]
    if any(("synthetic-room-0", s, "np") in index for s in table1):
        body = []
        for sampling, paper in table1.items():
            row = index.get(("synthetic-room-0", sampling, "np"))
            body.append([sampling[1:].replace("_", "/"),
                         f"{row['unknown_percent']:.1f} %" if row else "–",
                         f"{paper['np']:.2f}", f"{paper['bp']:.2f}",
                         _ratio(paper["bp"], paper["np"]),
                         ours("synthetic-room-0", sampling, "np"),
                         ours("synthetic-room-0", sampling, "bp"),
                         ours_ratio("synthetic-room-0", sampling)])
        header = ["rw/xw", "unknown (ours)", "paper NP", "paper BP", "paper BP/NP", "ours NP",
                  "ours BP", "ours BP/NP"]
        blocks.append(_titled("Table 1 analogue: synthetic room 0, 128×128 (m) — paper: USF "
                              "images (cm)", header, body))
    rooms = sorted({r["scene"] for r in rows if r["scene"].startswith("synthetic-room-")
                    and r["sampling"] == "g5_25" and r["size"] == "128x128"})
    if rooms:
        body = []
        for (label, paper), scene in zip(PAPER["Table 3 (USF 128×128, 61 %, cm)"].items(),
                                         rooms):
            body.append([label, f"{paper['np-noedges']:.2f} / {paper['np']:.2f} / "
                         f"{paper['bp']:.2f}", scene,
                         *(ours(scene, "g5_25", m) for m in ("np-noedges", "np", "bp"))])
        means = []
        for method in ("np-noedges", "np", "bp"):
            found = [index[scene, "g5_25", method]["mar"] for scene in rooms
                     if (scene, "g5_25", method) in index]
            means.append(f"{fsum_mean(found):.3f}" if found else "–")
        table2 = PAPER["Table 2 (USF 128×128, mean of 32 images at 61 %, cm)"]["mean"]
        body.append(["Table 2: mean of 32", f"– / {table2['np']:.2f} / {table2['bp']:.2f}",
                     f"mean of {len(rooms)} rooms", *means])
        header = ["paper image", "paper no-edge / NP / BP", "our scene", "ours no-edge",
                  "ours NP", "ours BP"]
        blocks.append(_titled("Table 3 analogue: rooms at g5_25, 128×128 (m) — paper: four "
                              "USF images at 61 % (cm)", header, body))
    moto = "motorcycle-450x375"
    if any((moto, s, "np") in index for s in ("x63", "x78", "x85")):
        body = []
        for sampling, paper in PAPER["Table 4 (Middlebury 450×375)"].items():
            row = index.get((moto, sampling, "np"))
            body.append([f"{sampling[1:]} % / {row['unknown_percent']:.1f} %" if row else "–",
                         f"{paper['np']:.2f}", f"{paper['bp']:.2f}",
                         _ratio(paper["bp"], paper["np"]), ours(moto, sampling, "np"),
                         ours(moto, sampling, "bp"), ours_ratio(moto, sampling)])
        header = ["unknown (paper / ours)", "paper NP", "paper BP", "paper BP/NP", "ours NP",
                  "ours BP", "ours BP/NP"]
        blocks.append(_titled("Table 4 analogue: Motorcycle 450×375, x-stripes (disparity "
                              "px) — paper: Middlebury images (its range units)", header, body))
        if (moto, "x63", "np-noisophotes") in index:
            body = [[sampling, ours(moto, sampling, "np-noisophotes"), ours(moto, sampling, "np")]
                    for sampling in ("x63", "x78", "x85")]
            blocks.append(_titled("Fig. 16 analogue: isophotes off / on — paper: 10.5 → 6.5 "
                                  "(65 %) and 12.2 → 7.3 (62 %)",
                                  ["sampling", "ours without isophotes", "ours with"], body))
    return "\n\n".join(blocks)

