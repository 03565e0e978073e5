"""NP, BP and the classical fills on a folder of real scenes × samplings, with the seeds' spread.

Every scene goes through Table 4's protocol (§3.3): the largest centred crop
of the target's aspect (6:5 for 450 × 375), an exact area resize
(:func:`refsynth.scenes.load_rgbd`), a sampling, and MAR (Eq. 13) over the
unknown pixels that have ground truth. Per scene × sampling the table gives
each method's MAR (mean ± sample standard deviation over ``--seeds`` for the
methods that draw at random, one run for the others), the best classical fill
(nearest, linear, colorization, joint-bilateral:
:mod:`refsynth.evaluation.baselines`) and each synthesis method's ratio to it;
the aggregate gives, per method, the geometric mean and the largest of those
ratios, over every case and per group of scenes, and the mean time of a fill.

Scenes
    ``FOLDER`` holds one sub-folder per scene. A sub-folder with a
    ``scene.json`` is read with :func:`refsynth.scenes.load_rgbd_folder`;
    the folders of ``../shared/data`` (which have none) are described in
    :data:`SHARED_SCENES` here: ``gt.npy`` (float32 in the stated unit, NaN
    where there is none) beside the image; the NYU frames are first cut to
    rows 45:471, cols 41:601 (inside their undistortion border).
    ``--motorcycle`` adds scikit-image's Middlebury 2014 *Motorcycle*
    (:func:`refsynth.scenes.motorcycle` at the size, as ``evaluate`` and the
    README's Table 4 load it: the whole pair area-resized).

Samplings (``refsynth.evaluation.cases.known_mask``)
    ``x63``, ``x78``: vertical stripes leaving 63 / 78 % unknown (Table 4);
    ``distance60``: Fig. 2's distance-driven columns, 60 % unknown, the coarse
    range the truth's column medians (its inverse for a disparity);
    ``g5_25``: Table 1's grid of 5-px known and 25-px unknown stripes.

Run::

    python benchmarks/bench_scenes.py ../shared/data --motorcycle --seeds 0 \\
        --json /work/notes/bench_scenes_baseline.json
    python benchmarks/bench_scenes.py ../shared/data --scenes nyu_basement_raw_00000 \\
        --samplings distance60 --methods np,linear --size 225x188
    python benchmarks/bench_scenes.py ../shared/data --motorcycle --seeds 0,1,2 \\
        --json runs.json --resume            # adds the runs runs.json lacks

``--variant LABEL=METHOD:KEY=VALUE,...`` adds a method of its own, e.g.
``--variant np-onion-value=np:ordering=onion,range_copy=value`` (keywords of
:func:`refsynth.synthesize`; values are read as JSON where they parse, as
strings otherwise).
"""

from __future__ import annotations

import argparse
import concurrent.futures
import functools
import json
import math
import multiprocessing
import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

try:
    import refsynth  # noqa: F401
except ImportError:  # run from a checkout without `pip install -e .`
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from refsynth._files import write_atomic  # noqa: E402
from refsynth.evaluation.baselines import BASELINES  # noqa: E402
from refsynth.evaluation.cases import (  # noqa: E402
    SYNTHESIS_METHODS,
    known_mask,
    parse_sampling,
    parse_size,
    size_tuple,
)
from refsynth.evaluation.metrics import evaluate  # noqa: E402
from refsynth.scenes import load_rgbd, load_rgbd_folder, motorcycle  # noqa: E402
from refsynth.scenes.rgbd import METADATA_FILE  # noqa: E402
from refsynth.synthesis.api import synthesize  # noqa: E402
from refsynth.synthesis.options import draws_at_random  # noqa: E402
from refsynth.synthesis.readings import split_options  # noqa: E402

#: The classical fills a synthesis method is compared with.
CLASSICAL = ("nearest", "linear", "colorization", "joint-bilateral")
DEFAULT_METHODS = ("np", "bp", *CLASSICAL)
DEFAULT_SAMPLINGS = ("x63", "x78", "distance60", "g5_25")
NYU_CROP = ((45, 471), (41, 601))

#: ``../shared/data``'s folders, which carry no scene.json: load_rgbd's arguments.
SHARED_SCENES = {
    **{f"nyu_basement_raw_{n:05d}": dict(image="image.jpg", truth="gt.npy", kind="depth",
                                         units="m", crop=NYU_CROP, invalid=None)
       for n in (0, 50, 100)},
    "kv2_livingroom_raw": dict(image="image.png", truth="gt.npy", kind="depth", units="m",
                               invalid=None),
    "mb2005_reindeer_half": dict(image="view1.png", truth="gt.npy", kind="disparity",
                                 units="disparity (px)", invalid=None),
}

#: Groups of the aggregate, by the scene's name.
GROUPS = (("motorcycle", "motorcycle"), ("indoor", "nyu_"), ("indoor", "kv2_"),
          ("tabletop", "mb"))

#: Extra methods: label -> fill(scene, known, seed) -> (range, seconds); set before the
#: worker processes fork (diagnose_distance.py registers its prototypes here).
EXTRA_METHODS: dict[str, Callable] = {}
#: Extra synthesize() variants: label -> keyword arguments (from --variant).
VARIANTS: dict[str, dict] = {}


def group_of(scene: str) -> str:
    """The aggregate's group of a scene's name (``other`` when none matches)."""
    for group, prefix in GROUPS:
        if scene.startswith(prefix):
            return group
    return "other"


# ----------------------------------------------------------------------------- scenes


def scene_specs(folder: str | None, motorcycle_too: bool, names: Sequence[str] | None,
                warn=print) -> list[tuple[str, str]]:
    """``(name, spec)`` of every scene: ``("motorcycle", "motorcycle")`` and folders' paths."""
    specs = []
    if motorcycle_too:
        specs.append(("motorcycle", "motorcycle"))
    if folder is not None:
        root = Path(folder)
        if not root.is_dir():
            raise ValueError(f"FOLDER must be a folder of scenes, got '{folder}'")
        for path in sorted(p for p in root.iterdir() if p.is_dir()):
            if (path / METADATA_FILE).is_file() or path.name in SHARED_SCENES:
                specs.append((path.name, str(path.resolve())))
            else:
                warn(f"skipped {path}: no {METADATA_FILE} and not a known folder")
    if names:
        unknown = sorted(set(names) - {name for name, _ in specs})
        if unknown:
            raise ValueError(f"--scenes names no scene: {', '.join(unknown)}")
        specs = [s for s in specs if s[0] in names]
    if not specs:
        raise ValueError("no scenes: give a FOLDER of scenes and/or --motorcycle")
    return specs


@functools.lru_cache(maxsize=4)
def load(spec: str, size: str):
    """The scene of a spec at a size (cached per process)."""
    dims = size_tuple(size)
    if spec == "motorcycle":
        return motorcycle(dims if dims is not None else (741, 500))
    path = Path(spec)
    if (path / METADATA_FILE).is_file():
        return load_rgbd_folder(path, size=dims)
    meta = dict(SHARED_SCENES[path.name])
    image, truth = path / meta.pop("image"), path / meta.pop("truth")
    return load_rgbd(image, truth, size=dims, name=path.name, **meta)


# ----------------------------------------------------------------------------- runs


def is_stochastic(method: str) -> bool:
    """Whether a method's result depends on its seed."""
    if method in EXTRA_METHODS:
        return getattr(EXTRA_METHODS[method], "stochastic", True)
    options = VARIANTS.get(method, SYNTHESIS_METHODS.get(method))
    return options is not None and draws_at_random(options)


def fill(scene, known: np.ndarray, method: str, seed: int) -> tuple[np.ndarray, float]:
    """The dense range of one method and its wall time."""
    partial = np.where(known, scene.range, np.nan)
    start = time.perf_counter()
    if method in EXTRA_METHODS:
        estimate = EXTRA_METHODS[method](scene, known, seed)
    elif method in BASELINES:
        estimate = BASELINES[method](scene.intensity, partial)
    else:
        options = VARIANTS.get(method, SYNTHESIS_METHODS.get(method))
        keywords, readings = split_options(options)
        estimate = synthesize(scene.intensity, partial, seed=seed, **keywords,
                              readings=readings).range
    return estimate, time.perf_counter() - start


def run_one(task: tuple) -> dict:
    """One fill, scored: ``task = (name, spec, size, sampling, method, seed)``."""
    name, spec, size, sampling, method, seed = task
    scene = load(spec, size)
    known = known_mask(scene, sampling)
    estimate, seconds = fill(scene, known, method, seed)
    scores = evaluate(estimate, scene.range, known)
    return dict(scene=name, size=size, units=scene.units, sampling=sampling, method=method,
                seed=seed, mar=scores["mar"], rmse=scores["rmse"], evaluated=scores["n"],
                unknown_percent=100.0 * float(np.mean(~known)), seconds=seconds)


def _key(row: dict) -> tuple:
    return (row["scene"], row["size"], row["sampling"], row["method"], row["seed"])


def tasks_for(specs, size, samplings, methods, seeds) -> list[tuple]:
    """Every (scene, sampling, method, seed) to run: the classical fills first, then NP, then
    BP (a long run that is stopped early still has whole columns), seed by seed."""
    tasks = []
    for name, spec in specs:
        for sampling in samplings:
            for method in methods:
                for seed in (seeds if is_stochastic(method) else seeds[:1]):
                    tasks.append((name, spec, size, sampling, method, seed))
    cost = {"np": 1, "bp": 2}
    return sorted(tasks, key=lambda t: (cost.get(t[4].split("-")[0], 0), t[5]))


def run(tasks: Sequence[tuple], jobs: int = 1, done: Sequence[dict] = (),
        on_row: Callable[[list[dict]], None] | None = None, progress=None) -> list[dict]:
    """Run the tasks not already in ``done``; ``on_row(rows)`` after each one."""
    rows = list(done)
    have = {_key(r) for r in rows}
    todo = [t for t in tasks if (t[0], t[2], t[3], t[4], t[5]) not in have]
    start = time.perf_counter()

    def record(row):
        rows.append(row)
        if on_row is not None:
            on_row(rows)
        if progress is not None:
            progress(f"[{len(rows) - len(done)}/{len(todo)}] {row['scene']} {row['sampling']} "
                     f"{row['method']} seed {row['seed']}: MAR {row['mar']:.4g} "
                     f"({row['seconds']:.1f} s; {time.perf_counter() - start:.0f} s in all)")

    if jobs <= 1:
        for task in todo:
            record(run_one(task))
        return rows
    context = multiprocessing.get_context("fork")
    with concurrent.futures.ProcessPoolExecutor(jobs, mp_context=context) as pool:
        for future in concurrent.futures.as_completed([pool.submit(run_one, t) for t in todo]):
            record(future.result())
    return rows


# ----------------------------------------------------------------------------- tables


def _mean_sd(values: Sequence[float]) -> tuple[float, float | None]:
    return math.fsum(values) / len(values), (float(np.std(values, ddof=1))
                                             if len(values) > 1 else None)


def summarise(rows: Sequence[dict], methods: Sequence[str]) -> dict:
    """Per case the methods' means and spreads, the best classical fill and the ratios."""
    cases: dict[tuple, dict] = {}
    for row in rows:
        case = cases.setdefault((row["scene"], row["sampling"]), dict(
            scene=row["scene"], sampling=row["sampling"], units=row["units"],
            unknown_percent=row["unknown_percent"], runs={}))
        case["runs"].setdefault(row["method"], []).append(row)
    table = []
    for case in cases.values():
        entry = {k: case[k] for k in ("scene", "sampling", "units", "unknown_percent")}
        entry["group"] = group_of(case["scene"])
        entry["methods"] = {}
        for method, runs in case["runs"].items():
            runs = sorted(runs, key=lambda r: r["seed"])
            mean, sd = _mean_sd([r["mar"] for r in runs])
            entry["methods"][method] = dict(
                mar=mean, sd=sd, seeds=[r["seed"] for r in runs],
                per_seed=[r["mar"] for r in runs],
                seconds=math.fsum(r["seconds"] for r in runs) / len(runs))
        classical = {m: v["mar"] for m, v in entry["methods"].items() if m in CLASSICAL}
        if classical:
            best = min(classical, key=classical.get)
            entry["best_classical"] = best
            for value in entry["methods"].values():
                value["ratio"] = value["mar"] / classical[best] if classical[best] > 0 else None
        table.append(entry)
    return dict(cases=table, aggregate=aggregate(table, methods))


def aggregate(table: Sequence[dict], methods: Sequence[str]) -> dict:
    """Per method and group: the geometric mean and the largest ratio, the mean time."""
    out = {}
    groups = ["all", *dict.fromkeys(entry["group"] for entry in table)]
    for method in methods:
        out[method] = {}
        for group in groups:
            chosen = [e for e in table if group in ("all", e["group"])
                      and e["methods"].get(method, {}).get("ratio") is not None]
            if not chosen:
                continue
            ratios = [e["methods"][method]["ratio"] for e in chosen]
            out[method][group] = dict(
                cases=len(chosen), geomean=float(np.exp(np.mean(np.log(ratios)))),
                worst=max(ratios), wins=sum(r <= 1.0 for r in ratios),
                seconds=float(np.mean([e["methods"][method]["seconds"] for e in chosen])))
    return out


def _fmt(value: dict | None) -> str:
    if value is None:
        return "–"
    text = f"{value['mar']:.4g}"
    if value.get("sd") is not None:
        text += f" ± {value['sd']:.2g}"
    return text


def format_tables(summary: dict, methods: Sequence[str]) -> str:
    """The per-case table and the aggregate, as Markdown."""
    synthesis = [m for m in methods if m not in CLASSICAL]
    header = ["scene", "sampling", "unknown", *methods, "best classical",
              *[f"{m} / best" for m in synthesis]]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for entry in summary["cases"]:
        values = entry["methods"]
        cells = [entry["scene"], entry["sampling"], f"{entry['unknown_percent']:.1f} %",
                 *[_fmt(values.get(m)) for m in methods], entry.get("best_classical", "–")]
        for method in synthesis:
            ratio = values.get(method, {}).get("ratio")
            cells.append("–" if ratio is None else f"{ratio:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "Aggregate: ratio to the best classical fill per case (geometric mean / "
              "worst / cases at or under 1.0), mean seconds per fill", "",
              "| method | group | cases | geomean | worst | ≤ 1.0 | seconds |",
              "|---|---|---|---|---|---|---|"]
    for method, groups in summary["aggregate"].items():
        for group, value in groups.items():
            lines.append(f"| {method} | {group} | {value['cases']} | {value['geomean']:.3f} | "
                         f"{value['worst']:.3f} | {value['wins']} | {value['seconds']:.2f} |")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- command line


def _value(text: str):
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return {"True": True, "False": False}.get(text, text)


def parse_variant(text: str) -> tuple[str, dict]:
    """``LABEL=METHOD:KEY=VALUE,...`` → ``(LABEL, synthesize keywords)``."""
    try:
        label, rest = text.split("=", 1)
        method, _, pairs = rest.partition(":")
        options = {"method": method} if method != "np" else {}
        for pair in filter(None, pairs.split(",")):
            key, value = pair.split("=", 1)
            options[key.strip()] = _value(value.strip())
    except ValueError:
        raise ValueError(f"--variant must be LABEL=METHOD:KEY=VALUE,..., got {text!r}") from None
    if method not in ("np", "bp") or not label:
        raise ValueError(f"--variant's METHOD must be np or bp, got {text!r}")
    return label.strip(), options


def split_list(text: str) -> list[str]:
    """``"a, b,,c"`` → ``["a", "b", "c"]``: a comma-separated option's items."""
    return [item.strip() for item in text.split(",") if item.strip()]


def add_scene_arguments(parser: argparse.ArgumentParser) -> None:
    """The options every scene benchmark takes: the folder, ``--motorcycle``, ``--scenes``
    and ``--size`` (read back by :func:`specs_from_arguments` and ``parse_size``)."""
    parser.add_argument("folder", nargs="?", default=None, help="a folder of scene folders")
    parser.add_argument("--motorcycle", action="store_true", help="add the Motorcycle")
    parser.add_argument("--scenes", default=None, help="comma-separated scene names to keep")
    parser.add_argument("--size", default="450x375", help="WxH (default 450x375) or native")


def specs_from_arguments(args: argparse.Namespace) -> list[tuple[str, str]]:
    """:func:`scene_specs` of the options :func:`add_scene_arguments` added, warnings on
    stderr."""
    return scene_specs(args.folder, args.motorcycle,
                       split_list(args.scenes) if args.scenes else None,
                       warn=lambda m: print(m, file=sys.stderr))


def main(argv: Sequence[str] | None = None, out=None) -> int:
    out = out or sys.stdout
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_scene_arguments(parser)
    parser.add_argument("--methods", default=",".join(DEFAULT_METHODS))
    parser.add_argument("--samplings", default=",".join(DEFAULT_SAMPLINGS))
    parser.add_argument("--seeds", default="0,1,2", help="comma-separated seeds (default 0,1,2)")
    parser.add_argument("--variant", action="append", default=[],
                        help="LABEL=METHOD:KEY=VALUE,... (a synthesize() variant)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument("--json", default=None, help="write the runs and the summary here")
    parser.add_argument("--resume", action="store_true",
                        help="keep the runs already in --json, run the others")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    try:
        for text in args.variant:
            label, options = parse_variant(text)
            VARIANTS[label] = options
        size = parse_size(args.size)
        samplings = [parse_sampling(s) for s in split_list(args.samplings)]
        methods = split_list(args.methods)
        known = {*SYNTHESIS_METHODS, *BASELINES, *VARIANTS, *EXTRA_METHODS}
        bad = [m for m in methods if m not in known]
        if bad or not methods:
            raise ValueError(f"--methods: unknown {bad}; choose from {sorted(known)}")
        seeds = [int(s) for s in split_list(args.seeds)]
        if not seeds or min(seeds) < 0:
            raise ValueError("--seeds must list non-negative integers")
        if args.jobs < 1:
            raise ValueError("--jobs must be >= 1")
        if args.resume and not args.json:
            raise ValueError("--resume needs --json")
        specs = specs_from_arguments(args)
    except ValueError as error:
        print(f"bench_scenes.py: {error}", file=sys.stderr)
        return 2
    done = []
    if args.resume and Path(args.json).is_file():
        done = json.loads(Path(args.json).read_text())["runs"]
    tasks = tasks_for(specs, size, samplings, methods, seeds)
    keys = {(t[0], t[2], t[3], t[4], t[5]) for t in tasks}

    def save(rows):
        if args.json:
            payload = dict(command=" ".join(sys.argv), runs=rows,
                           summary=summarise([r for r in rows if _key(r) in keys], methods))
            text = json.dumps(payload, indent=1, allow_nan=True)
            write_atomic(args.json, text.encode())

    progress = None if args.quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    rows = run(tasks, args.jobs, done, on_row=save, progress=progress)
    save(rows)
    summary = summarise([r for r in rows if _key(r) in keys], methods)
    print(f"bench_scenes: size {size}, seeds {','.join(map(str, seeds))}, "
          f"{len(specs)} scenes, MAR (Eq. 13) in each scene's unit", file=out)
    print(format_tables(summary, methods), file=out)
    return 0


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sys.exit(main())
