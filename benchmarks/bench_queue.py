"""NP's fill-order queue alone, replayed with blocks of every size (issue #15, item 4).

:class:`refsynth.synthesis.frontqueue.FrontQueue` keeps one bound per block of keys: a
pop scans ``N / block`` bounds and then a block, an update raises a few dozen bounds. This
script records every call NP makes to its queue on the Motorcycle (x-stripes 78 %, as
``bench_speed.py``), then replays the same calls on queues with blocks of 8 to 2048 keys
(``--rounds`` times, interleaved), and prints the CPU µs per fill step and the bounds pop
found loose (``retries``) for each, beside the default's block. The pops return the same
pixels whatever the block (the first maximum of the keys), so only the time differs.

Run::

    python benchmarks/bench_queue.py                     # 112x94 and 900x750
    python benchmarks/bench_queue.py --sizes 450x375 --rounds 5

Needs scikit-image (the Motorcycle).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_speed import _case, _size  # noqa: E402

BLOCKS = (8, 16, 32, 64, 128, 256, 512, 1024, 2048)


def record(size: tuple[int, int]) -> list[tuple]:
    """Every call NP's fill makes to its queue at ``size``: (name, arrays...) in order."""
    import importlib

    import refsynth

    frontqueue = importlib.import_module("refsynth.synthesis.frontqueue")
    # by import_module: refsynth.synthesis.priority is also the name of a function
    priority = importlib.import_module("refsynth.synthesis.priority")

    queue_class = frontqueue.FrontQueue
    log: list[tuple] = []

    class Recording(queue_class):
        def __init__(self, tie, block=None):
            log.append(("init", np.array(tie, copy=True)))
            super().__init__(tie, block)

        def set(self, pixels, keys):
            log.append(("set", np.array(pixels, copy=True), np.array(keys, copy=True)))
            super().set(pixels, keys)

        def set_in_blocks(self, slots, blocks, keys):
            log.append(("set_in_blocks", np.array(slots, copy=True), np.array(keys, copy=True)))
            super().set_in_blocks(slots, blocks, keys)

        def pop(self):
            log.append(("pop",))
            return super().pop()

    image, partial, _ = _case(size)
    frontqueue.FrontQueue = Recording
    saved = priority.FrontQueue
    priority.FrontQueue = Recording
    try:
        refsynth.synthesize(image, partial, seed=0)
    finally:
        frontqueue.FrontQueue = queue_class
        priority.FrontQueue = saved
    return log


def replay(log: list[tuple], block: int | None) -> tuple[float, int, int, int]:
    """CPU seconds of the calls after the first ``set`` (the fill), retries, block, pops."""
    from refsynth.synthesis.frontqueue import FrontQueue

    queue, start, pops = None, 0.0, 0
    for call in log:
        if call[0] == "init":
            queue = FrontQueue(call[1], block)
            shift = np.array(queue.shift)
        elif call[0] == "set":
            queue.set(call[1], call[2])
            start = time.process_time()
        elif call[0] == "set_in_blocks":
            queue.set_in_blocks(call[1], np.right_shift(call[1], shift), call[2])
        else:
            queue.pop()
            pops += 1
    return time.process_time() - start, queue.retries, queue.block, pops


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=lambda t: [_size(s) for s in t.split(",")],
                        default=[(112, 94), (900, 750)])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args(argv)
    print("| size | keys N | block | µs per step (best) | retries |")
    print("|---|---|---|---|---|")
    for size in args.sizes:
        log = record(size)
        n = log[0][1].size
        blocks = [None] + [b for b in BLOCKS if b <= n]
        best = {b: np.inf for b in blocks}
        for _ in range(args.rounds):
            for b in blocks:
                seconds, retries, used, pops = replay(log, b)
                best[b] = min(best[b], 1e6 * seconds / pops)
                label = f"{used} (default)" if b is None else str(used)
                if _ == args.rounds - 1:
                    print(f"| {size[0]}×{size[1]} | {n} | {label} | {best[b]:.2f} | {retries} |",
                          flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
