"""What each piece of NP's and BP's speed machinery buys, measured by taking it out.

The Motorcycle (scikit-image's copy) at ``--size`` (450×375 by default), x-stripes at 78 %
unknown, as ``bench_speed.py`` builds it. Each piece of machinery is switched off by
replacing it, for the measurement, with the simple array code it accelerates (the
replacements are below, each beside the piece it replaces; each gives the same output, bit
for bit, which the table checks). Every run is a fresh subprocess (this script with
``--child``), so that its peak memory is its own: the high-water mark of its resident
memory (``VmHWM``, reset before the fill where Linux allows it) less the resident memory
with the scene built, before the fill. The
runs are interleaved: each round runs the whole machinery and every variant once, in an
order rotated from round to round, so that a burst of load on this shared machine hits
them alike. The table gives, per piece, the median wall seconds with and without it over
the rounds, their spread (min–max), the ratio of the medians (without / with: above 1.10,
the piece buys more than 10 % of the method's time), the median CPU-seconds ratio, the
peak memory with and without, and whether the output is the same bits.

Run::

    python benchmarks/bench_machinery.py                       # NP and BP, 3 rounds (~30 min)
    python benchmarks/bench_machinery.py --methods np --rounds 5
    python benchmarks/bench_machinery.py --pieces frontqueue,shortlist --size 225x188
    git worktree add /tmp/speed-base main        # then: this checkout against main
    python benchmarks/bench_machinery.py --against /tmp/speed-base --rounds 3

Needs scikit-image (the Motorcycle).
"""

from __future__ import annotations

import argparse
import hashlib
import heapq
import importlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_speed import _case, _size  # noqa: E402

# ---------------------------------------------------------------------------------------
# The simple replacements, one per piece: each a function that patches the package in this
# (child) process.


def _table_hook(after):
    """Run ``after(table)`` at the end of every FillTable's construction."""
    from refsynth.synthesis import filltable

    init = filltable.FillTable.__init__

    def patched(self, *args, **kwargs):
        init(self, *args, **kwargs)
        after(self)

    filltable.FillTable.__init__ = patched


def no_shortlist() -> None:
    """No shortlist: Eq. 2 of every candidate of the disc, every step
    (``FillTable.distances``)."""
    def after(table):
        step = table._shortlister()
        table.shortlist_step = lambda p, candidates, scale: step(p, candidates, scale, True)

    _table_hook(after)


class HeapQueue:
    """FrontQueue's interface on ``heapq`` with stale entries: the largest key first, ties
    to the smallest slot (``tie``), as FrontQueue pops."""

    def __init__(self, tie, block=None):
        from refsynth.synthesis.frontqueue import ABSENT

        self.absent = int(ABSENT)
        self.rank = np.asarray(tie, dtype=np.int64).ravel()
        self.pixel_at = np.empty_like(self.rank)
        self.pixel_at[self.rank] = np.arange(self.rank.size)
        self.keys = [self.absent] * self.rank.size  # by slot
        self.pixels = self.pixel_at.tolist()
        self.heap: list[tuple[int, int]] = []
        self.shift = 0  # set_in_blocks's blocks are the slots

    def set(self, pixels, keys):
        self.set_slots(self.rank[pixels], keys)

    def set_slots(self, slots, keys):
        heap, own, absent = self.heap, self.keys, self.absent
        for slot, key in zip(np.ravel(slots).tolist(), np.ravel(keys).tolist()):
            if own[slot] != key:
                own[slot] = key
                if key != absent:
                    heapq.heappush(heap, (-key, slot))

    def set_in_blocks(self, slots, blocks, keys):
        self.set_slots(slots, keys)

    def pop(self):
        heap, own = self.heap, self.keys
        while heap:
            key, slot = heapq.heappop(heap)
            if own[slot] == -key:
                own[slot] = self.absent
                return self.pixels[slot]
        return -1


def heap_queue() -> None:
    """NP's fill order by a binary heap with stale entries instead of FrontQueue."""
    priority = _priority_module()

    priority.FrontQueue = HeapQueue


def _priority_module():
    """refsynth.synthesis.priority, the module (the package's name is also a function's)."""
    return importlib.import_module("refsynth.synthesis.priority")


def plain_ranking() -> None:
    """BP's candidate ranking by ``np.argsort(kind="stable")`` instead of
    belief/ranking.py's partitions."""
    from refsynth.synthesis.belief import search as bp_search

    def stable_smallest(values, count):
        return np.argsort(values, axis=1, kind="stable")[:, :count]

    def smallest_measured(values, bi, mi, b, m, count):
        d = np.full((b, m), np.inf)
        d[bi, mi] = values
        best = np.argsort(d, axis=1, kind="stable")[:, :count]
        return best, np.take_along_axis(d, best, axis=1)

    bp_search.stable_smallest, bp_search.smallest_measured = stable_smallest, smallest_measured


class _EveryEdge:
    """numpy, except that ``flatnonzero`` names every entry: belief_propagation's next
    sweep's nodes and edges are then all of them (plain synchronous sweeps). (Its other
    user, the bounded Ψ cache, is not used where every edge's Ψ fits, as at 450×375.)"""

    def __getattr__(self, name):
        return getattr(np, name)

    @staticmethod
    def flatnonzero(x):
        return np.arange(np.size(x))


def every_edge() -> None:
    """Every message sent at every sweep, instead of only those whose inputs changed."""
    from refsynth.synthesis.belief import messages

    messages.np = _EveryEdge()


def plain_max_product() -> None:
    """Eq. 9's max-product send as one ``max`` over an (m, k, k) sum, and numpy's own row
    reductions, instead of the label-by-label running maximum in cache-sized blocks."""
    from refsynth.synthesis.belief import messages

    def max_product(out, h, log_psi, axis):
        t = log_psi + (h[:, :, None] if axis == 1 else h[:, None, :])
        np.max(t, axis=axis, out=out)
        out -= out.max(axis=1, keepdims=True)

    messages._max_product = max_product
    messages._row_any = lambda x: np.any(x, axis=1)
    messages._row_max = lambda x: x.max(axis=1, keepdims=True)


#: piece -> (method, what the replacement is, the patch). The method's full machinery is the
#: baseline every piece is compared with.
PIECES = {
    "shortlist": ("np", "Eq. 2 of every candidate", no_shortlist),
    "frontqueue": ("np", "heapq with stale entries", heap_queue),
    "bp_ranking": ("bp", "np.argsort(kind='stable')", plain_ranking),
    "changed-only sends": ("bp", "every edge every sweep", every_edge),
    "label-wise max": ("bp", "one max over (m, k, k)", plain_max_product),
}


# ---------------------------------------------------------------------------------------


def _status_mb(field: str) -> float:
    with open("/proc/self/status", encoding="ascii") as status:
        for line in status:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024.0
    raise OSError(f"no {field} in /proc/self/status")


def _child(method: str, piece: str, size: tuple[int, int]) -> None:
    """One run: ``method`` with ``piece`` replaced (``-``: the whole machinery); JSON out."""
    import refsynth

    image, partial, _ = _case(size)
    if piece != "-":
        PIECES[piece][2]()
    try:  # the high-water mark reset to the resident memory now (Linux)
        with open("/proc/self/clear_refs", "w", encoding="ascii") as clear:
            clear.write("5")
    except OSError:
        pass
    before = _status_mb("VmRSS")
    wall, cpu = time.perf_counter(), time.process_time()
    if method == "np":
        out = refsynth.synthesize(image, partial, seed=0)
    else:
        out = refsynth.synthesize(image, partial, method="bp", seed=0)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    digest = hashlib.sha256(np.ascontiguousarray(out.range).tobytes()
                            + np.ascontiguousarray(out.confidence).tobytes()).hexdigest()
    print(json.dumps({"wall": wall, "cpu": cpu, "peak": _status_mb("VmHWM") - before,
                      "hash": digest[:16], "package": str(Path(refsynth.__file__).parents[1])}))


def _run(method: str, piece: str, size: tuple[int, int], package: str | None = None) -> dict:
    """One child run; ``package``: a folder whose ``refsynth`` the child imports instead."""
    cmd = [sys.executable, __file__, "--child", method, piece, f"{size[0]}x{size[1]}"]
    env = None
    if package is not None:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            [package] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    done = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env)
    if done.returncode:
        raise RuntimeError(f"{method} without {piece} failed:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _stats(values):
    return float(np.median(values)), float(min(values)), float(max(values))


def run(methods, pieces, size, rounds: int, out=sys.stdout) -> dict:
    """Time every method's full machinery and each piece's replacement, interleaved."""
    runs: dict[tuple[str, str], list[dict]] = {}
    variants = [(m, "-") for m in methods] + [(PIECES[p][0], p) for p in pieces
                                               if PIECES[p][0] in methods]
    for r in range(rounds):
        shift = r % len(variants)
        for method, piece in variants[shift:] + variants[:shift]:
            result = _run(method, piece, size)
            runs.setdefault((method, piece), []).append(result)
            print(f"  round {r + 1}: {method} {'(all)' if piece == '-' else 'without ' + piece}:"
                  f" {result['wall']:.1f} s", file=sys.stderr, flush=True)
    print(f"\nThe Motorcycle at {size[0]}×{size[1]}, x-stripes 78 % unknown; {rounds} rounds, "
          "median (min–max) wall seconds; ratios of the medians (without / with)\n", file=out)
    print("| piece | method | replaced by | with (s) | without (s) | wall ratio | CPU ratio "
          "| peak MB with / without | same bits |", file=out)
    print("|---|---|---|---|---|---|---|---|---|", file=out)
    table = {}
    for method in methods:
        base = runs[(method, "-")]
        bw, bl, bh = _stats([x["wall"] for x in base])
        bc = float(np.median([x["cpu"] for x in base]))
        bp = float(np.median([x["peak"] for x in base]))
        print(f"| (all) | {method} | | {bw:.1f} ({bl:.1f}–{bh:.1f}) | | | | {bp:.0f} | |",
              file=out)
        for piece in pieces:
            if PIECES[piece][0] != method:
                continue
            mine = runs[(method, piece)]
            w, lo, hi = _stats([x["wall"] for x in mine])
            c = float(np.median([x["cpu"] for x in mine]))
            peak = float(np.median([x["peak"] for x in mine]))
            same = {x["hash"] for x in mine} == {x["hash"] for x in base}
            table[piece] = {"wall_ratio": w / bw, "cpu_ratio": c / bc, "same": same}
            print(f"| {piece} | {method} | {PIECES[piece][1]} | {bw:.1f} ({bl:.1f}–{bh:.1f}) "
                  f"| {w:.1f} ({lo:.1f}–{hi:.1f}) | {w / bw:.2f} | {c / bc:.2f} "
                  f"| {bp:.0f} / {peak:.0f} | {'yes' if same else 'NO'} |", file=out)
    return table


def against(methods, package: str, size, rounds: int, out=sys.stdout) -> dict:
    """Each method with this checkout's refsynth and with the one in ``package`` (a folder
    holding another checkout), interleaved: the ratio of this one's time to that one's."""
    here = str(Path(__file__).resolve().parents[1])
    runs: dict[tuple[str, str], list[dict]] = {}
    variants = [(m, where) for m in methods for where in (package, here)]
    for r in range(rounds):
        shift = r % len(variants)
        for method, where in variants[shift:] + variants[:shift]:
            result = _run(method, "-", size, where)
            if Path(result["package"]) != Path(where):
                raise RuntimeError(f"the child imported {result['package']}, not {where}")
            runs.setdefault((method, where), []).append(result)
            print(f"  round {r + 1}: {method} ({where}): {result['wall']:.1f} s",
                  file=sys.stderr, flush=True)
    print(f"\nThe Motorcycle at {size[0]}×{size[1]}, x-stripes 78 % unknown; {rounds} rounds, "
          f"median (min–max) wall seconds; before: {package}, after: {here}\n", file=out)
    print("| method | before (s) | after (s) | wall ratio | CPU ratio | peak MB before / after "
          "| same bits |", file=out)
    print("|---|---|---|---|---|---|---|", file=out)
    table = {}
    for method in methods:
        before, after = runs[(method, package)], runs[(method, here)]
        bw, bl, bh = _stats([x["wall"] for x in before])
        aw, al, ah = _stats([x["wall"] for x in after])
        bc, ac = (float(np.median([x["cpu"] for x in v])) for v in (before, after))
        bp, ap = (float(np.median([x["peak"] for x in v])) for v in (before, after))
        same = {x["hash"] for x in before} == {x["hash"] for x in after}
        table[method] = {"wall_ratio": aw / bw, "cpu_ratio": ac / bc, "same": same}
        print(f"| {method} | {bw:.1f} ({bl:.1f}–{bh:.1f}) | {aw:.1f} ({al:.1f}–{ah:.1f}) "
              f"| {aw / bw:.2f} | {ac / bc:.2f} | {bp:.0f} / {ap:.0f} "
              f"| {'yes' if same else 'NO'} |", file=out)
    return table


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--size", type=_size, default=(450, 375))
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--methods", type=lambda t: t.split(","), default=["np", "bp"])
    parser.add_argument("--pieces", type=lambda t: t.split(","), default=list(PIECES))
    parser.add_argument("--against", metavar="FOLDER",
                        help="compare the whole methods with another checkout's refsynth "
                             "(e.g. a git worktree of main) instead of piece by piece")
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        method, piece, size = args.child
        _child(method, piece, _size(size))
        return 0
    if args.against:
        against(args.methods, str(Path(args.against).resolve()), args.size, args.rounds)
        return 0
    unknown = [p for p in args.pieces if p not in PIECES]
    if unknown:
        parser.error(f"unknown pieces {unknown}; choose from {list(PIECES)}")
    run(args.methods, args.pieces, args.size, args.rounds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
