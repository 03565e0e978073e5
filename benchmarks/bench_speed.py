"""Speed and memory of every fill at real sizes, in one process (issue #15, items 4 and 6).

The Middlebury 2014 *Motorcycle* (scikit-image's copy) resized to 112×94, 225×188,
450×375 and 900×750, x-stripes at 78 % unknown (as ``bench_np.py`` and ``bench_bp.py``
build it). For each size, NP and BP (:func:`refsynth.synthesize`) and the colorization,
nearest and joint-bilateral fills (:mod:`refsynth.evaluation.baselines`) run on the same
input **in this process**, one after the other, ``--repeat`` times (the best time is
kept, the methods interleaved so that a burst of load on this shared machine hits them
alike). The table gives, per method and size:

- the wall-clock seconds (``time.perf_counter``) and the ratio to the colorization fill
  of the same run (the issue's targets: NP ≤ 5×, BP ≤ 6× at 450×375 and ≤ 5× at 900×750);
- the CPU seconds of this process (``time.process_time``, all its threads) and their
  ratio: on a machine that other work shares, wall time counts the waits for a core and
  CPU time does not, so the two ratios bracket what a quiet machine would show;
- µs per unknown pixel, in wall and in CPU time (linear cost: the same at every size,
  within ±25 %, issue item 4);
- for BP, the sweeps of Eq. 9 it ran (``BPResult.iterations``);
- the peak resident memory: each (method, size) runs once more in a **fresh
  subprocess** (this script with ``--child``), which reports the high-water mark of its
  own address space, ``VmHWM`` of ``/proc/self/status``, beside the same subprocess's
  peak with the scene built and no fill run. (``ru_maxrss``, of ``RUSAGE_SELF``,
  ``RUSAGE_CHILDREN`` or ``os.wait4``, is no good here: Linux carries the parent's
  peak across fork/vfork and exec into the child's, so every child would report at
  least this process's own peak. Where there is no ``/proc``, ``ru_maxrss`` is
  reported, and the output says so.)

A last line per method compares µs per unknown pixel at the smallest and the largest
size: the linearity check of item 4.

Run::

    python benchmarks/bench_speed.py                   # all sizes and methods (~10 min)
    python benchmarks/bench_speed.py --quick           # 112×94 and 225×188 only
    python benchmarks/bench_speed.py --sizes 450x375 --methods np,colorization --repeat 3
    python benchmarks/bench_speed.py --sizes 450x375,900x750 --no-rss \
        --methods np,bp,bp-colorization,colorization    # BP on NP's fill and on colorization
    python benchmarks/bench_speed.py --bp-stages       # BP's stages, CPU time (~3 min)
    python benchmarks/bench_speed.py --bp-stages --observation np   # BP's default's (~5 min)
    python benchmarks/bench_speed.py --np-steps        # NP's shortlist per step (~3 min)
    python benchmarks/bench_speed.py --fill-solvers    # BP's observations' fill (~3 min)
    python benchmarks/bench_speed.py --fill-solvers --room   # the same on the room's grids
    python benchmarks/bench_speed.py --memory 2048x2048  # item 3: NP and both BPs, ~20 min

``--memory SIZE`` runs NP, BP and BP on the colorization fill once each at ``SIZE`` in a
fresh subprocess and prints,
beside each one's memory estimate (the one ``synthesize`` refuses a run by), its peak
resident memory, the subprocess's peak with the scene alone, and its wall time (scene
included): issue #15 item 3, an image up to 2048×2048 within 4 GB or refused up front.

Needs scikit-image (the Motorcycle).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

SIZES = ((112, 94), (225, 188), (450, 375), (900, 750))
QUICK_SIZES = SIZES[:2]
#: ``bp`` is BP's default (0.9: NP's fill, then BP), ``bp-colorization`` 0.4–0.8's default BP
#: (the observations completed by the colorization fill).
METHODS = ("np", "bp", "bp-colorization", "bp-fig6", "colorization", "nearest",
           "joint-bilateral")
#: Chosen by name only (``--methods``): ``bp`` under its 0.8 name (NP's fill, then BP).
OPTIONAL_METHODS = ("bp-obs-np",)
UNKNOWN = 0.78  # x-stripes, as bench_np.py / bench_bp.py
#: The fills ``--memory`` measures, beside their estimates.
MEMORY_METHODS = ("np", "bp", "bp-colorization")
LINEAR_TOLERANCE = 0.25  # issue #15 item 4: µs per unknown pixel within ±25 %
#: Issue #15 item 2: BP within 6× the colorization fill at 450×375 and 5× at 900×750
#: (``--bp-stages``' budget; 6× at any other size).
BP_TARGETS = {(450, 375): 6.0, (900, 750): 5.0}
#: The observations ``--bp-stages`` can time BP on (``--observation``).
BP_STAGE_OBSERVATIONS = ("colorization", "np")


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"a size is WIDTHxHEIGHT, e.g. 450x375, got {text!r}") from None
    if width < 8 or height < 8:
        raise argparse.ArgumentTypeError(f"a size must be at least 8x8, got {text!r}")
    return width, height


def _case(size: tuple[int, int]):
    """The Motorcycle at ``size`` (width, height) with x-stripes at 78 % unknown."""
    from refsynth.acquisition.sampling import unknown_fraction, x_stripes_for_fraction
    from refsynth.scenes import motorcycle

    scene = motorcycle(size)
    known = x_stripes_for_fraction(scene.range.shape, UNKNOWN) & scene.has_truth
    partial = np.where(known, scene.range, np.nan)
    return scene.intensity, partial, 100.0 * unknown_fraction(known)


def _bp_target(size: tuple[int, int]) -> float:
    """Issue #15's bound on BP's time at ``size``, in colorization fills (6× where it names
    none)."""
    return BP_TARGETS.get(tuple(size), 6.0)


def _fill(method: str):
    """The fill ``method`` as ``fill(intensity, partial) -> dense range``."""
    import refsynth
    from refsynth.evaluation import baselines

    return {
        "np": lambda image, partial: refsynth.synthesize(image, partial, seed=0),
        "bp": lambda image, partial: refsynth.synthesize(image, partial, method="bp", seed=0),
        "bp-colorization": lambda image, partial: refsynth.synthesize(
            image, partial, method="bp", readings={"observation": "colorization"}),
        "bp-fig6": lambda image, partial: refsynth.synthesize(
            image, partial, method="bp", readings={"observation": "measured",
                                                   "training_radius": "fixed",
                                                   "range_copy": "value"}),
        "bp-obs-np": lambda image, partial: refsynth.synthesize(image, partial, method="bp", seed=0,
                                                                readings={"observation": "np"}),
        "colorization": baselines.colorization_fill,
        "nearest": baselines.nearest_fill,
        "joint-bilateral": baselines.joint_bilateral_fill,
    }[method]


def _own_peak_mb() -> tuple[float, str]:
    """This process's peak RSS in MB, and how it was read (see the module's docstring)."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0, "VmHWM"
    except OSError:
        pass
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux, bytes on macOS
    return (rss / 1024.0 if sys.platform != "darwin" else rss / 1024.0**2), "ru_maxrss"


def _own_rss_mb() -> float | None:
    """This process's resident memory now in MB (``VmRSS``), or None without ``/proc``."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


def _child(method: str, size: tuple[int, int]) -> None:
    """Run one fill (or, for ``"scene"``, only build the input); print as JSON the peak RSS
    and the RSS just before the fill (the scene built)."""
    image, partial, _ = _case(size)
    before = _own_rss_mb()
    if method != "scene":
        _fill(method)(image, partial)
    peak, how = _own_peak_mb()
    print(json.dumps({"peak_mb": peak, "how": how, "before_mb": before}))


def _child_report(method: str, size: tuple[int, int]) -> dict:
    """What :func:`_child` prints, from a fresh subprocess running one fill."""
    command = [sys.executable, os.path.abspath(__file__), "--child", method,
               f"{size[0]}x{size[1]}"]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed ({done.returncode}): {done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _peak_rss_mb(method: str, size: tuple[int, int]) -> tuple[float, str]:
    """Peak RSS (MB) of a fresh subprocess running one fill, and how it was read."""
    report = _child_report(method, size)
    return report["peak_mb"], report["how"]


def memory_at(size: tuple[int, int], methods=MEMORY_METHODS) -> None:
    """Item 3: each fill at ``size`` in a fresh subprocess, beside its memory estimate."""
    from refsynth.synthesis.belief.memory import BP_MEMORY_LIMIT, bp_memory_estimate
    from refsynth.synthesis.limits import np_memory

    image, partial, percent = _case(size)
    unknown = np.isnan(partial)
    pairs = int(np.count_nonzero(unknown[:, :-1] & unknown[:, 1:])
                + np.count_nonzero(unknown[:-1, :] & unknown[1:, :]))
    estimates = {
        "np": np_memory(partial.shape, image.shape[2], 5, 10.0),
        "bp-colorization": bp_memory_estimate(partial.shape, int(unknown.sum()),
                                              n_pairs=pairs),
    }
    # BP's default runs NP first, then BP: each is checked (and peaks) on its own
    estimates["bp"] = max(estimates["np"], estimates["bp-colorization"])
    scene, how = _peak_rss_mb("scene", size)
    print(f"Motorcycle {size[0]}×{size[1]}, x-stripes {percent:.0f} % unknown "
          f"({int(unknown.sum())} pixels); resident memory of a fresh subprocess in MiB "
          f"(peak: {how}; before: VmRSS with the scene built, just before the fill); the "
          f"scene alone peaks at {scene:.0f} MiB while it is built. BP is refused above "
          f"{BP_MEMORY_LIMIT / 2**20:.0f} MiB of estimate, NP above this machine's memory.")
    print()
    print("| method | estimate MiB | before MiB | peak MiB | peak less before MiB "
          "| peak within 4 GiB | wall s (scene included) |")
    print("|---|---|---|---|---|---|---|")
    for method in methods:
        start = time.perf_counter()
        report = _child_report(method, size)
        seconds = time.perf_counter() - start
        peak, before = report["peak_mb"], report["before_mb"]
        added = f"{peak - before:.0f}" if before is not None else "—"
        before = f"{before:.0f}" if before is not None else "—"
        print(f"| {method} | {estimates[method] / 2**20:.0f} | {before} | {peak:.0f} | {added} "
              f"| {'yes' if peak <= 4096 else 'no'} | {seconds:.0f} |", flush=True)


def _time(methods, image, partial, repeat: int):
    """The best of ``repeat`` wall and CPU times of each method, interleaved, in this
    process, and BP's sweep count."""
    fills = {method: _fill(method) for method in methods}
    best = dict.fromkeys(methods, np.inf)
    cpu = dict.fromkeys(methods, np.inf)
    sweeps = {}
    for _ in range(repeat):
        for method, fill in fills.items():
            start, start_cpu = time.perf_counter(), time.process_time()
            result = fill(image, partial)
            best[method] = min(best[method], time.perf_counter() - start)
            cpu[method] = min(cpu[method], time.process_time() - start_cpu)
            if hasattr(result, "iterations") and method.startswith("bp"):
                sweeps[method] = int(result.iterations)
    return best, cpu, sweeps


def run(sizes, methods, repeat: int = 1, rss: bool = True, out=sys.stdout) -> dict:
    """Time every method at every size and print the table; return the measurements.

    Returns
    -------
    dict
        ``{(width, height): {"unknown": int, "fraction": float, "seconds": {method: s},
        "cpu": {method: s}, "sweeps": {"bp": int}, "rss": {method: MB, "scene": MB}}}``.
    """
    results = {}
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"Motorcycle, x-stripes {100 * UNKNOWN:.0f} % unknown; best of {repeat} wall time(s) "
          f"in one process; load average {load:.2f} at the start.", file=out)
    how = _peak_rss_mb("scene", sizes[0])[1] if rss else None
    if how is not None:
        print(f"Peak RSS: each (method, size) in a fresh subprocess, its own {how}"
              + (" (the subprocess's own address space)" if how == "VmHWM" else
                 " (may include this process's peak, inherited at fork)")
              + "; 'scene alone' builds the input and runs no fill.\n", file=out)
    print("| size | unknown pixels | method | wall s | / colorization | CPU s | / colorization "
          "| µs per unknown pixel (wall, CPU) | peak RSS MB (scene alone) |", file=out)
    print("|---|---|---|---|---|---|---|---|---|", file=out)
    for size in sizes:
        image, partial, fraction = _case(size)
        unknown = int(np.isnan(partial).sum())
        seconds, cpu, sweeps = _time(methods, image, partial, repeat)
        peaks = {}
        if rss:
            peaks = {m: _peak_rss_mb(m, size)[0] for m in ("scene", *methods)}
        results[size] = dict(unknown=unknown, fraction=fraction, seconds=seconds, cpu=cpu,
                             sweeps=sweeps, rss=peaks)
        reference, reference_cpu = seconds.get("colorization"), cpu.get("colorization")
        for method in methods:
            ratio = f"{seconds[method] / reference:.2g}×" if reference else "—"
            ratio_cpu = f"{cpu[method] / reference_cpu:.2g}×" if reference_cpu else "—"
            memory = (f"{peaks[method]:.0f} ({peaks['scene']:.0f})" if rss else "—")
            label = f"{method} ({sweeps[method]} sweeps)" if method in sweeps else method
            print(f"| {size[0]}×{size[1]} | {unknown} ({fraction:.0f} %) | {label} | "
                  f"{seconds[method]:.3f} | {ratio} | {cpu[method]:.3f} | {ratio_cpu} | "
                  f"{1e6 * seconds[method] / unknown:.3g}, {1e6 * cpu[method] / unknown:.3g} | "
                  f"{memory} |", file=out, flush=True)
    _linearity(results, methods, out, "seconds", "wall")
    _linearity(results, methods, out, "cpu", "CPU")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"\nLoad average {load:.2f} at the end.", file=out)
    return results


def bp_stages(sizes, out=sys.stdout, observation: str = "colorization") -> dict:
    """CPU time of each of BP's stages, read from its progress reports, beside the
    colorization fill's time and what issue #15's target leaves the observations' fill.

    ``observation``: ``"colorization"`` (0.4–0.8's defaults: the observations completed by
    the colorization fill) or ``"np"`` (BP's default since 0.9: NP's fill first). BP reports
    per mille of its work, each stage within its share (the observations' fill's,
    :data:`refsynth.synthesis.api.OBSERVATION_SHARE` or ``NP_OBSERVATION_SHARE``, then
    :data:`refsynth.synthesis.belief.fill.BP_STAGES`); a stage ends at the first report at or
    past the end of its share (the first stage's time includes what comes before the fill: the
    checks, the quantisation and Canny). Beside each stage's CPU time: µs per unknown pixel,
    its measured share of the whole and the share assumed; with ``"colorization"``, the
    sweeps of the colorization fill on the same input (``portable_colorization``, the
    observations' solver, on the unquantised input: its count, not its bits).

    Then, per size, the baseline :func:`refsynth.evaluation.baselines.colorization_fill`
    timed in the same process (CPU, best of two) and the budget of issue #15's
    BP target (:data:`BP_TARGETS`): what BP's own stages (all but the observations' fill) take
    of it, and so how long the observations' fill may take for the whole to stay within it.

    Returns
    -------
    dict
        ``{(width, height): {"unknown": int, "sweeps": int | None, "stages": {name: CPU s},
        "colorization": CPU s}}``.
    """
    import refsynth
    from refsynth.evaluation.baselines import colorization_fill
    from refsynth.synthesis.api import NP_OBSERVATION_SHARE, OBSERVATION_SHARE
    from refsynth.synthesis.belief.fill import BP_STAGES
    from refsynth.synthesis.completion import portable_colorization

    if observation not in BP_STAGE_OBSERVATIONS:
        raise ValueError(f"The parameter `observation` must be one of "
                         f"{BP_STAGE_OBSERVATIONS}, got {observation!r}")
    first, first_share = {"colorization": ("observations' fill", OBSERVATION_SHARE),
                          "np": ("NP's fill (the observations)", NP_OBSERVATION_SHARE)}[
        observation]
    names = [first] + [name for name, _ in BP_STAGES]
    rest = sum(share for _, share in BP_STAGES)
    shares = [first_share] + [(1 - first_share) * share / rest for _, share in BP_STAGES]
    ends = np.cumsum(shares) * 1000
    which = ("0.4's defaults" if observation == "colorization"
             else "BP's default: NP's fill, then BP")
    print(f"BP's stages ({which}) in CPU time, from its progress reports; "
          "Motorcycle, x-stripes 78 % unknown\n", file=out)
    print("| size | stage | CPU s | µs per unknown pixel | share measured | share assumed |",
          file=out)
    print("|---|---|---|---|---|---|", file=out)
    results = {}
    for size in sizes:
        image, partial, _ = _case(size)
        unknown = int(np.isnan(partial).sum())
        sweeps = None
        if observation == "colorization":
            _, sweeps = portable_colorization(image, partial, return_sweeps=True)
            sweeps = int(sweeps)
        seen = []
        start = time.process_time()
        refsynth.synthesize(image, partial, method="bp", seed=0,
                            progress=lambda done, total, seen=seen, start=start: seen.append(
                                (time.process_time() - start, done)),
                            readings={"observation": observation})
        # a stage's end, in whole per mille, is reached to within 2 (two roundings down)
        stamps = [next(t for t, done in seen if done >= end - 2) for end in ends]
        times = np.diff([0.0, *stamps])
        total = stamps[-1]
        reference = np.inf
        for _ in range(2):
            begin = time.process_time()
            colorization_fill(image, partial)
            reference = min(reference, time.process_time() - begin)
        results[size] = dict(unknown=unknown, sweeps=sweeps,
                             stages=dict(zip(names, (float(t) for t in times), strict=True)),
                             colorization=float(reference))
        for name, seconds, share in zip(names, times, shares, strict=True):
            label = f"{name} ({sweeps} sweeps)" if sweeps is not None and name == names[0] \
                else name
            print(f"| {size[0]}×{size[1]} | {label} | {seconds:.3f} | "
                  f"{1e6 * seconds / unknown:.3g} | {seconds / total:.0%} | {share:.0%} |",
                  file=out, flush=True)
    print("\nThe budget of BP's target (issue #15: ≤ 6× the colorization fill at 450×375, "
          "≤ 5× at 900×750; 6× elsewhere), CPU time in this process:", file=out)
    for size, r in results.items():
        target = _bp_target(size)
        own = sum(list(r["stages"].values())[1:])
        fill = r["stages"][names[0]]
        budget = target * r["colorization"]
        left = budget - own
        print(f"- {size[0]}×{size[1]}: the colorization fill {r['colorization']:.3f} s, "
              f"{target:g}× = {budget:.3f} s; BP's own stages {own:.3f} s "
              f"({own / r['colorization']:.2g}×) leave {left:.3f} s "
              f"({left / r['colorization']:.2g}×) to the observations' fill, which took "
              f"{fill:.3f} s ({fill / r['colorization']:.2g}×): "
              f"{(own + fill) / r['colorization']:.2g}× in all, "
              f"{'within' if own + fill <= budget else 'over'} {target:g}×", file=out)
    if len(results) > 1:
        print("\nµs per unknown pixel by stage, smallest to largest size:", file=out)
        for name in names:
            per = [1e6 * r["stages"][name] / r["unknown"] for r in results.values()]
            print(f"- {name}: " + " / ".join(f"{v:.3g}" for v in per)
                  + f" (max/min {max(per) / max(min(per), 1e-12) - 1:+.0%})", file=out)
    return results


def np_steps(sizes, out=sys.stdout) -> dict:
    """What NP's steps do at each size: the shortlist's work, which the data decides.

    NP's step costs more when more of Eq. 3's candidates survive the shortlist's bound
    (:attr:`refsynth.synthesis.filltable.FillTable.shortlist_step`: their range term is then
    evaluated and Eq. 5 draws among them) and less when only the candidate that set the
    bound survives (no second gather, no draw). Counted on NP's default fill (the same
    bits as ``synthesize``: the counting wraps the method and changes nothing it
    returns), beside the CPU µs per unknown pixel of a separate run without the counting.

    Returns
    -------
    dict
        ``{(width, height): {"unknown", "steps", "candidates", "kept", "single", "many",
        "cpu"}}``: the steps counted, the mean
        number of candidates and of kept candidates per step, the share of steps that keep
        one, the mean kept where more than one is, and the CPU seconds of the uncounted run.
    """
    import refsynth
    from refsynth.synthesis.filltable import FillTable

    print("NP's steps on the Motorcycle, x-stripes 78 % unknown: the candidates of Eq. 3 "
          "within r, those the shortlist keeps for Eq. 2's range term, and the steps that "
          "keep one\n", file=out)
    print("| size | unknown pixels | candidates per step | kept per step | steps keeping one "
          "| kept per step where more than one | CPU µs per unknown pixel |", file=out)
    print("|---|---|---|---|---|---|---|", file=out)
    init = FillTable.__init__
    results = {}
    for size in sizes:
        image, partial, _ = _case(size)
        unknown = int(np.isnan(partial).sum())
        start = time.process_time()
        refsynth.synthesize(image, partial, method="np")
        cpu = time.process_time() - start
        counts = []

        def counting(self, *args, counts=counts, **kwargs):
            init(self, *args, **kwargs)
            shortlist = self.shortlist_step  # what NP's loop calls, wrapped on this table

            def counted(p, candidates, scale, every=False):
                kept, distances = shortlist(p, candidates, scale, every)
                counts.append((candidates.size, kept.size))
                return kept, distances

            self.shortlist_step = counted

        FillTable.__init__ = counting
        try:
            refsynth.synthesize(image, partial, method="np")
        finally:
            FillTable.__init__ = init
        steps = np.array(counts, dtype=np.float64).reshape(-1, 2)
        many = steps[steps[:, 1] > 1, 1]
        row = dict(unknown=unknown, steps=len(counts), candidates=float(steps[:, 0].mean()),
                   kept=float(steps[:, 1].mean()), single=float(np.mean(steps[:, 1] == 1)),
                   many=float(many.mean()) if many.size else 1.0, cpu=cpu)
        results[size] = row
        print(f"| {size[0]}×{size[1]} | {unknown} | {row['candidates']:.1f} | "
              f"{row['kept']:.1f} | {row['single']:.0%} | {row['many']:.1f} | "
              f"{1e6 * cpu / unknown:.1f} |", file=out, flush=True)
    return results


def fill_solvers(sizes, out=sys.stdout) -> dict:
    """BP's observations' fill by the cascade and by Gauss–Seidel alone, on the same inputs.

    ``portable_colorization`` (``solver="cascadic"``, 0.7's, and ``"gauss-seidel"``, 0.6's)
    on the Motorcycle's x-stripes at 63 / 78 / 85 % unknown (stripe phase 0): CPU µs per
    unknown pixel, the sweeps run on the image itself, and the fill's MAR against the ground
    truth beside the direct solve's (``colorization_fill``, SuperLU). Returns
    ``{(width, height, percent, solver): {"us": float, "sweeps": int, "mar": float}}``.
    """
    from refsynth.acquisition.sampling import x_stripes_for_fraction
    from refsynth.evaluation.baselines import colorization_fill
    from refsynth.evaluation.metrics import mar
    from refsynth.scenes import motorcycle
    from refsynth.synthesis.completion import SOLVERS, portable_colorization

    print("BP's observations' fill (portable_colorization), Motorcycle, x-stripes, phase 0: "
          "CPU µs per unknown pixel, the sweeps on the image itself, MAR (px) against the "
          "ground truth\n", file=out)
    print("| size | unknown | solver | µs per unknown pixel | sweeps | MAR | direct solve's MAR |",
          file=out)
    print("|---|---|---|---|---|---|---|", file=out)
    results = {}
    for size in sizes:
        scene = motorcycle(size)
        for percent in (63, 78, 85):
            known = x_stripes_for_fraction(scene.range.shape, percent / 100) & scene.has_truth
            partial = np.where(known, scene.range, np.nan)
            unknown = int((~known).sum())
            direct = mar(colorization_fill(scene.intensity, partial), scene.range, known)
            for solver in SOLVERS:
                start = time.process_time()
                fill, sweeps = portable_colorization(scene.intensity, partial, solver=solver,
                                                     return_sweeps=True)
                us = 1e6 * (time.process_time() - start) / unknown
                score = mar(fill, scene.range, known)
                results[size + (percent, solver)] = dict(us=us, sweeps=int(sweeps), mar=score)
                print(f"| {size[0]}×{size[1]} | {percent} % | {solver} | {us:.3g} | {sweeps} | "
                      f"{score:.4f} | {direct:.4f} |", file=out, flush=True)
    for solver in SOLVERS:
        for percent in (63, 78, 85):
            per = [r["us"] for key, r in results.items() if key[2:] == (percent, solver)]
            print(f"- {solver}, {percent} %: " + " / ".join(f"{v:.3g}" for v in per)
                  + f" µs per unknown pixel (max/min {max(per) / min(per) - 1:+.0%})", file=out)
    return results


#: The room's grids of ``evaluate``'s default grid: (the known lines' width, the unknown
#: holes' side) in pixels (``stripes(shape, known, hole, axes="xy")``), widest holes first.
ROOM_GRIDS = ((24, 80), (10, 20), (5, 25), (3, 28))


def fill_solvers_room(out=sys.stdout, grids=ROOM_GRIDS) -> dict:
    """:func:`fill_solvers` on the synthetic room (128×128, seed 0), with BP beside each fill.

    The fill's MAR (m) against the ground truth for each solver and the direct solve, and
    BP's (its defaults, ``observation="colorization"``) with its observations filled by each
    solver. ``grids``: pairs (known lines' width, unknown holes' side). Returns
    ``{(grid, solver): {"fill": float, "bp": float}}`` (``"direct"``: the direct solve's
    fill only).
    """
    import refsynth
    from refsynth.acquisition.sampling import stripes
    from refsynth.evaluation.baselines import colorization_fill
    from refsynth.evaluation.metrics import mar
    from refsynth.scenes import synthetic_room
    from refsynth.synthesis.completion import SOLVERS, portable_colorization

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # this script's folder
    from audit_departures import _fill_solver  # BP's observations filled by a given solver

    print("BP's observations' fill on the synthetic room (128×128, seed 0), grids (known "
          "lines' width / unknown holes' side, px): the fill's MAR (m) against the ground "
          "truth, and BP's (defaults) with its observations filled by that solver\n", file=out)
    print("| grid | unknown | solver | fill's MAR | BP's MAR |", file=out)
    print("|---|---|---|---|---|", file=out)
    scene = synthetic_room((128, 128), seed=0)
    results = {}
    for line, hole in grids:
        grid = f"{line}/{hole}"
        known = stripes(scene.range.shape, line, hole, axes="xy") & scene.has_truth
        partial = np.where(known, scene.range, np.nan)
        percent = 100.0 * (~known).mean()
        direct = mar(colorization_fill(scene.intensity, partial), scene.range, known)
        results[(grid, "direct")] = dict(fill=direct)
        print(f"| {grid} | {percent:.1f} % | direct (SuperLU) | {direct:.3f} | — |", file=out)
        for solver in SOLVERS:
            fill = portable_colorization(scene.intensity, partial, solver=solver)
            with _fill_solver(solver):
                bp = refsynth.synthesize(scene.intensity, partial, method="bp",
                                         readings={"observation": "colorization"}).range
            results[(grid, solver)] = dict(fill=mar(fill, scene.range, known),
                                           bp=mar(bp, scene.range, known))
            print(f"| {grid} | {percent:.1f} % | {solver} | {results[(grid, solver)]['fill']:.3f}"
                  f" | {results[(grid, solver)]['bp']:.3f} |", file=out, flush=True)
    return results


def _linearity(results: dict, methods, out, key: str = "seconds", what: str = "wall") -> None:
    """µs per unknown pixel (``key``: wall or CPU seconds) from the smallest to the largest
    size, against ±25 %."""
    sizes = list(results)
    if len(sizes) < 2:
        return
    first, last = sizes[0], sizes[-1]
    print(f"\nLinearity in {what} time (µs per unknown pixel, {first[0]}×{first[1]} → "
          f"{last[0]}×{last[1]}, target ±{100 * LINEAR_TOLERANCE:.0f} %):", file=out)
    for method in methods:
        per_pixel = [1e6 * results[s][key][method] / results[s]["unknown"] for s in sizes]
        change = per_pixel[-1] / per_pixel[0] - 1.0
        spread = max(per_pixel) / min(per_pixel) - 1.0
        verdict = "within" if abs(change) <= LINEAR_TOLERANCE else "outside"
        print(f"- {method}: {per_pixel[0]:.3g} → {per_pixel[-1]:.3g} µs ({change:+.0%}, "
              f"{verdict} ±{100 * LINEAR_TOLERANCE:.0f} %; max/min over all sizes "
              f"{spread:+.0%})", file=out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=lambda t: [_size(s) for s in t.split(",")],
                        help="comma-separated WIDTHxHEIGHT (default: 112x94,225x188,450x375,"
                        "900x750)")
    parser.add_argument("--methods", type=lambda t: t.split(","), default=list(METHODS),
                        help=f"comma-separated, of {', '.join(METHODS + OPTIONAL_METHODS)} "
                        f"(default: all but {', '.join(OPTIONAL_METHODS)})")
    parser.add_argument("--repeat", type=int, default=1,
                        help="time each method this many times, keep the best (default 1)")
    parser.add_argument("--quick", action="store_true",
                        help="112x94 and 225x188 only")
    parser.add_argument("--no-rss", action="store_true",
                        help="skip the peak-RSS subprocesses (timings only)")
    parser.add_argument("--bp-stages", action="store_true",
                        help="instead: the CPU time of each of BP's stages, read from its "
                        "progress reports, and the observations' fill's sweeps")
    parser.add_argument("--observation", choices=BP_STAGE_OBSERVATIONS,
                        help="with --bp-stages: BP on the colorization fill's observations "
                        "(the default) or on NP's fill (BP's default since 0.9)")
    parser.add_argument("--fill-solvers", action="store_true",
                        help="instead: BP's observations' fill by the cascade and by "
                        "Gauss-Seidel alone, its time, sweeps and MAR")
    parser.add_argument("--room", action="store_true",
                        help="with --fill-solvers: on the synthetic room's grids (128x128), "
                        "the fills' MAR and BP's with each")
    parser.add_argument("--np-steps", action="store_true",
                        help="instead: NP's shortlist per step at each size (candidates, "
                        "those kept for Eq. 2's range term, steps keeping one)")
    parser.add_argument("--memory", type=_size, metavar="SIZE",
                        help="instead: NP's and BP's peak memory at SIZE (e.g. 2048x2048) "
                        "beside their estimates, each in a fresh subprocess")
    parser.add_argument("--child", nargs=2, metavar=("METHOD", "SIZE"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        _child(args.child[0], _size(args.child[1]))
        return 0
    unknown = sorted(set(args.methods) - set(METHODS + OPTIONAL_METHODS))
    if unknown:
        parser.error(f"unknown method(s) {', '.join(unknown)}; choose from "
                     f"{', '.join(METHODS + OPTIONAL_METHODS)}")
    if args.repeat < 1:
        parser.error(f"--repeat must be >= 1, got {args.repeat}")
    if args.quick and args.sizes:
        parser.error("--quick and --sizes are exclusive")
    sizes = QUICK_SIZES if args.quick else (args.sizes or SIZES)
    if args.observation is not None and not args.bp_stages:
        parser.error("--observation goes with --bp-stages")
    if args.bp_stages:
        bp_stages(sizes, observation=args.observation or "colorization")
        return 0
    if args.np_steps:
        np_steps(sizes)
        return 0
    if args.room and not args.fill_solvers:
        parser.error("--room goes with --fill-solvers")
    if args.fill_solvers:
        if args.room:
            fill_solvers_room()
        else:
            fill_solvers(sizes)
        return 0
    if args.memory:
        memory_at(args.memory, [m for m in args.methods if m in MEMORY_METHODS]
                  or list(MEMORY_METHODS))
        return 0
    run(sizes, args.methods, repeat=args.repeat, rss=not args.no_rss)
    return 0


if __name__ == "__main__":
    sys.exit(main())
