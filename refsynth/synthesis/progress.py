r"""Progress over the stages of a fill, as one ``progress(done, total)`` callback.

:func:`refsynth.synthesize` reports progress through one callback,
``progress(done, total)``. NP counts pixels. BP's work is in stages of
different kinds — the observations' fill (Gauss–Seidel sweeps), the candidate
search (Fig. 6, step 2: nodes), the compatibilities (step 4) and the messages
(step 5: sweeps of Eq. 9) — so it reports **per mille of its estimated
work**: each stage has a share of the total (:class:`StagedProgress`), and
reports its own fraction done within it. The shares are the stages' measured
shares of BP's time on the Motorcycle (x-stripes, 450×375 and 900×750;
``python benchmarks/bench_speed.py --bp-stages``), so that the time left
that :func:`refsynth.cli.synth.pixel_progress` prints is an estimate, not a
promise. The reports never go backwards and end at ``(total, total)``.

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Fig. 6 (the stages of BP),
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

__all__ = ["PER_MILLE", "StagedProgress", "Progress"]

#: A ``progress(done, total)`` callback.
Progress = Callable[[int, int], None]

#: The ``total`` of a staged report: BP's progress is per mille of its work.
PER_MILLE = 1000


class StagedProgress:
    """One callback's progress over stages that each report their own fraction.

    Parameters
    ----------
    progress : callable or None
        ``progress(done, total)``, called with ``total =`` :data:`PER_MILLE`;
        None: nothing is reported (every stage's callback is then None).
    shares : sequence of float
        Each stage's share of the work, >= 0 (they are normalised to sum to 1).

    Examples
    --------
    >>> seen = []
    >>> staged = StagedProgress(lambda done, total: seen.append(done), [1, 3])
    >>> first, second = staged.stage(0), staged.stage(1)
    >>> first(1, 2); first(2, 2); second(1, 3); staged.finish()
    >>> seen
    [125, 250, 500, 1000]
    """

    def __init__(self, progress: Progress | None, shares: Sequence[float]) -> None:
        total = float(sum(shares))
        if not shares or total <= 0 or any(share < 0 for share in shares):
            raise ValueError(f"The stages' shares must be >= 0 and not all 0, got {shares!r}")
        self._progress = progress
        self._starts = []
        running = 0.0
        for share in shares:
            self._starts.append(running / total)
            running += share
        self._starts.append(1.0)
        self._done = -1

    def stage(self, index: int) -> Progress | None:
        """The callback of stage ``index``: ``report(done, total)`` within its share."""
        if self._progress is None:
            return None
        start, stop = self._starts[index], self._starts[index + 1]

        def report(done: float, total: float) -> None:
            fraction = min(max(done / total, 0.0), 1.0) if total > 0 else 1.0
            self._report(int((start + (stop - start) * fraction) * PER_MILLE))

        return report

    def complete(self, index: int) -> None:
        """Report stage ``index`` done (the start of the next)."""
        report = self.stage(index)
        if report is not None:
            report(1, 1)

    def finish(self) -> None:
        """Report the whole work done: ``progress(PER_MILLE, PER_MILLE)``."""
        if self._progress is not None:
            self._report(PER_MILLE)

    def _report(self, done: int) -> None:
        done = min(done, PER_MILLE)
        if done > self._done:  # never backwards, no repeats
            self._done = done
            self._progress(done, PER_MILLE)
