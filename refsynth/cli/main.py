"""The command line: ``python -m refsynth demo | synth | scan | register | evaluate | figures``.

Errors print one line on stderr and exit with status 2, without a traceback.
Long runs report progress on stderr.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

__all__ = ["main", "run_demo", "run_pipeline_demo"]

#: The demo's methods: NP, its two ablations of Table 3 / Fig. 7, and BP.
DEMO_METHODS = {
    "NP": {},
    "NP, no edges": {"use_edges": False},
    "NP, onion order": {"ordering": "onion"},
    "BP": {"method": "bp"},
}


class CliError(Exception):
    """A user error: printed as one line, exit status 2."""


def _progress(label: str):
    """A progress callback writing ``label: done/total`` on one stderr line."""
    if not sys.stderr.isatty():
        return None
    start = time.perf_counter()

    def report(done: int, total: int) -> None:
        end = "\n" if done >= total else ""
        rate = done / max(time.perf_counter() - start, 1e-9)
        print(f"\r{label}: {done}/{total} pixels ({rate:,.0f}/s)", end=end, file=sys.stderr)

    return report


def _format_table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    header = [title for _, title, _ in columns]
    body = [[format(row[key], fmt) if fmt else str(row[key]) for key, _, fmt in columns]
            for row in rows]
    widths = [max(len(h), *(len(r[i]) for r in body)) for i, h in enumerate(header)]
    line = lambda cells: "  ".join(c.ljust(w) for c, w in zip(cells, widths))  # noqa: E731
    return "\n".join([line(header), line(["-" * w for w in widths]), *map(line, body)])


def run_demo(out: Path, size: int = 128, seed: int = 0) -> list[dict]:
    """The main job on the bundled synthetic room; returns the table's rows.

    Two samplings (grid stripes rw/xw = 5/25, about 61 % unknown, as in Table 1;
    vertical x-stripes at 78 % unknown, as in Table 4) × NP with priority order,
    NP without edges, NP with onion-peel order, BP, and the nearest-neighbour,
    linear and harmonic fills. Writes ``demo_result.png`` (the paper's layout,
    NP on the grid sampling), ``demo_np_bp.png`` (NP's and BP's results,
    residuals and confidence maps) and ``demo_comparison.png`` (every sampling
    × method) into ``out``.
    """
    from refsynth import synthesize
    from refsynth.acquisition.sampling import stripes, unknown_fraction, x_stripes_for_fraction
    from refsynth.evaluation.baselines import BASELINES
    from refsynth.evaluation.metrics import evaluate
    from refsynth.plotting.layouts import comparison_figure, methods_figure, result_figure
    from refsynth.scenes.datasets import synthetic_room

    scene = synthetic_room((size, size), seed=seed)
    shape = scene.range.shape
    samplings = {
        "grid 5/25": stripes(shape, 5, 25, axes="xy"),
        "x-stripes 78%": x_stripes_for_fraction(shape, 0.78),
    }
    rows, partials, results = [], {}, {}
    full: dict = {}
    for sampling, known in samplings.items():
        partial = np.where(known, scene.range, np.nan)
        partials[sampling] = partial
        for method, kwargs in [*DEMO_METHODS.items(), *((name, None) for name in BASELINES)]:
            start = time.perf_counter()
            if kwargs is None:
                estimate = BASELINES[method](scene.intensity, partial)
            else:
                res = synthesize(
                    scene.intensity, partial, seed=seed,
                    progress=_progress(f"{sampling}, {method}"), **kwargs,
                )
                estimate = res.range
                full[(sampling, method)] = res
            seconds = time.perf_counter() - start
            results[(sampling, method)] = estimate
            scores = evaluate(estimate, scene.range, known)
            rows.append(dict(sampling=sampling, unknown=100 * unknown_fraction(known),
                             method=method, seconds=seconds, **scores))
    out.mkdir(parents=True, exist_ok=True)
    sampling = next(iter(samplings))
    res = full[(sampling, "NP")]
    fig = result_figure(scene.intensity, res.edges, partials[sampling], res.range, scene.range,
                        units=scene.units, title=f"{scene.name}: NP, {sampling}")
    fig.savefig(out / "demo_result.png", dpi=110)
    fig = methods_figure(
        scene.range, partials[sampling],
        {m: (full[(sampling, m)].range, full[(sampling, m)].confidence) for m in ("NP", "BP")},
        units=scene.units, title=f"{scene.name}, {sampling}: NP and BP",
    )
    fig.savefig(out / "demo_np_bp.png", dpi=110)
    fig = comparison_figure(scene.range, partials, results, units=scene.units,
                            title=f"{scene.name}, seed {seed}: MAR (Eq. 13) per method")
    fig.savefig(out / "demo_comparison.png", dpi=110)
    return rows


def run_pipeline_demo(out: Path, seed: int = 0, methods=("np", "bp")) -> dict:
    """Acquire (simulated) → register → synthesize: the paper's pipeline end to end.

    Scans the simulated rig's room (40 % of the 500 slices, stripes; pictures
    every 18°) into ``out/scan`` unless a scan is already there, registers the
    pictures and the partial scan (Appendix A), fills the panorama's missing
    range with each method and writes ``pipeline_<method>.png``. Returns a
    summary dict.
    """
    from refsynth import synthesize
    from refsynth.acquisition import (
        PanUnit,
        Rangefinder,
        RigSimulator,
        ScanSettings,
        load_scan,
        run_scan,
    )
    from refsynth.io import read_array
    from refsynth.plotting.layouts import result_figure
    from refsynth.registration.laser_camera import register_scan

    scan_dir = out / "scan"
    if not (scan_dir / "scan.npz").is_file():
        with RigSimulator(seed=seed, camera_dir=scan_dir / "images") as sim, \
                PanUnit(sim.pan_port) as pan, Rangefinder(sim.laser_port) as laser:
            run_scan(scan_dir, pan, laser, ScanSettings("stripes", fraction=0.4))
    scan = load_scan(scan_dir)
    images = [read_array(picture.path) for picture in scan.images]
    angles = [picture.pan_angle for picture in scan.images]
    intensity, partial, info = register_scan(images, angles, 300.0, (scan.r, scan.theta, scan.phi))
    summary = dict(panorama=intensity.shape, known=float(np.isfinite(partial).mean()),
                   warp=tuple(float(v) for v in info.warp), seconds={})
    out.mkdir(parents=True, exist_ok=True)
    for method in methods:
        start = time.perf_counter()
        result = synthesize(intensity, partial, method=method, seed=seed,
                            progress=_progress(f"pipeline, {method}"))
        summary["seconds"][method] = time.perf_counter() - start
        fig = result_figure(intensity, result.edges, partial, result.range, units="m",
                            title=f"simulated rig, registered panorama: {method.upper()}")
        fig.savefig(out / f"pipeline_{method}.png", dpi=110)
    return summary


def _cmd_demo(args) -> int:
    if args.pipeline:
        summary = run_pipeline_demo(Path(args.out), seed=args.seed)
        h, w = summary["panorama"]
        print(f"refsynth demo --pipeline: simulated scan ({args.out}/scan), registered panorama "
              f"{w}x{h}, {100 * summary['known']:.0f} % with range; warp a, b, alpha, beta = "
              + ", ".join(f"{v:.2f}" for v in summary["warp"]))
        for method, seconds in summary["seconds"].items():
            figure = Path(args.out) / f"pipeline_{method}.png"
            print(f"{method.upper()}: {seconds:.1f} s -> {figure}")
        return 0
    if args.size < 16:
        raise CliError(f"--size must be at least 16, got {args.size}")
    rows = run_demo(Path(args.out), size=args.size, seed=args.seed)
    print(f"refsynth demo: synthetic room {args.size}x{args.size}, seed {args.seed}, range in m")
    print(_format_table(rows, [
        ("sampling", "sampling", ""), ("unknown", "unknown %", ".1f"), ("method", "method", ""),
        ("mar", "MAR (m)", ".4f"), ("rmse", "RMSE (m)", ".4f"), ("seconds", "seconds", ".2f"),
    ]))
    names = ("demo_result.png", "demo_np_bp.png", "demo_comparison.png")
    print("figures: " + ", ".join(str(Path(args.out) / name) for name in names))
    return 0


def _read(path: str, what: str) -> np.ndarray:
    from refsynth.io import read_array

    if not Path(path).is_file():
        raise CliError(f"{what} file not found: {path}")
    return read_array(path)


def _cmd_synth(args) -> int:
    from refsynth import synthesize

    intensity = _read(args.image, "image")
    partial = _read(args.range, "range").astype(np.float64)
    if partial.ndim == 3:
        raise CliError(f"range file must hold a single channel, got shape {partial.shape}")
    if Path(args.range).suffix.lower() not in (".npy", ".pfm"):
        partial[partial == 0] = np.nan  # image files: 0 marks unknown range
    partial[np.isinf(partial)] = np.nan  # PFM: inf marks unknown
    if args.mask is not None:
        mask = _read(args.mask, "mask")
        if mask.ndim == 3:
            mask = mask.mean(axis=2)
        if mask.shape != partial.shape:
            raise CliError(f"mask shape {mask.shape} differs from range shape {partial.shape}")
        partial = np.where(mask > 0, partial, np.nan)
    result = synthesize(
        intensity, partial, method=args.method, seed=args.seed,
        neighbourhood=args.neighbourhood, radius=args.radius, epsilon=args.epsilon,
        use_edges=not args.no_edges, use_isophotes=not args.no_isophotes,
        ordering=args.ordering, progress=_progress("synthesizing"),
    )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    np.save(out, result.range)
    print(f"wrote {out}: {result.range.shape[0]}x{result.range.shape[1]} range, "
          f"{len(result.order)} pixels synthesized")
    if args.figure:
        from refsynth.plotting.layouts import result_figure

        fig = result_figure(intensity, result.edges, partial, result.range,
                            title=f"{Path(args.image).name}: {args.method.upper()}")
        fig.savefig(args.figure, dpi=110)
        print(f"wrote {args.figure}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m refsynth",
        description="Range synthesis from intensity and partial range "
        "(Torres-Méndez & Dudek, IJCV 2008).",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="run the main job on the bundled synthetic room")
    demo.add_argument("--out", default="refsynth-demo", help="folder for the figures")
    demo.add_argument("--size", type=int, default=128, help="image side in pixels (default 128)")
    demo.add_argument("--seed", type=int, default=0, help="scene and synthesis seed")
    demo.add_argument("--pipeline", action="store_true",
                      help="acquire with the simulated rig, register, then synthesize "
                      "(instead of the pre-aligned synthetic room)")
    demo.set_defaults(func=_cmd_demo)

    synth = sub.add_parser("synth", help="fill the unknown range of your own image")
    synth.add_argument("image", help="intensity image: PNG/JPG/NPY/PFM")
    synth.add_argument("range", help="partial range: NPY/PFM (NaN or inf = unknown) "
                       "or PNG (0 = unknown)")
    synth.add_argument("--out", required=True, help="output .npy file")
    synth.add_argument("--mask", help="known-range mask (nonzero = known) applied to RANGE")
    synth.add_argument("--figure", help="also write a PNG figure here")
    synth.add_argument("--method", default="np", choices=["np", "bp"])
    synth.add_argument("--seed", type=int, default=0)
    synth.add_argument("--neighbourhood", type=int, default=5)
    synth.add_argument("--radius", type=float, default=10.0)
    synth.add_argument("--epsilon", type=float, default=0.1)
    synth.add_argument("--ordering", default="priority", choices=["priority", "onion"])
    synth.add_argument("--no-edges", action="store_true")
    synth.add_argument("--no-isophotes", action="store_true")
    synth.set_defaults(func=_cmd_synth)

    from refsynth.cli.evaluate import add_evaluate_parser
    from refsynth.cli.figures import add_figures_parser
    from refsynth.cli.register import add_register_parser
    from refsynth.cli.scan import add_scan_parser

    add_scan_parser(sub)
    add_register_parser(sub)
    add_evaluate_parser(sub)
    add_figures_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (CliError, ValueError, TypeError, OSError, ImportError) as exc:
        print(f"refsynth {args.command}: error: {exc}", file=sys.stderr)
        return 2
