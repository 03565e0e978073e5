r"""The memory BP needs (§3.2.3, Fig. 6), estimated before any work.

:func:`refsynth.synthesis.belief.fill.bp_fill` holds, for ``N`` unknown pixels with
``k`` candidates each and ``E ≤ 2N`` pairs of unknown 4-neighbours:

- per pixel of the image, the quantised intensity and range and the patch
  rows' sources of the candidate search (:mod:`refsynth.synthesis.belief.search`);
- per node, the candidates, their distances and values, the unary terms and
  the beliefs (``k`` float64 or int64 each);
- per pair, its two messages (``2k`` float64) and the bookkeeping of the
  schedule (:func:`refsynth.synthesis.belief.messages.belief_propagation`);
- blocks of bounded size for the search, Ψ and the sends.

Ψ (``E·k²`` float64, 522 MB at 900×750) is *not* held: the sends compute it
block by block, and :attr:`refsynth.synthesis.belief.fill.BPResult.log_psi` computes
the whole array on first access (:func:`psi_bytes` says how much that takes).
:func:`bp_memory_estimate` is an upper bound of the peak resident memory BP adds
to the process, calibrated on the Motorcycle (x-stripes, 78 % unknown) from
225×188 to 2048×2048 (``python benchmarks/bench_speed.py --memory SIZE`` prints the
estimate beside the measured peak; without Ψ's cache and the margin per node it falls
10–23 % under it); :func:`check_bp_memory` refuses, up front, a call that
would need more than a limit (:data:`BP_MEMORY_LIMIT`, 4 GiB, by default).

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Fig. 6, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

__all__ = ["BP_MEMORY_LIMIT", "bp_memory_estimate", "psi_bytes", "check_bp_memory"]

#: The default limit of :func:`check_bp_memory`, in bytes (4 GiB).
BP_MEMORY_LIMIT = 4 * 2**30

_FLOAT = 8
_BLOCKS = 96 * 2**20  # the bounded blocks of the search, Ψ and the sends
_PSI_CACHE = 1 << 27  # Ψ's rows kept between sweeps (messages._PSI_CACHE), when E k² fills it
#: Float64 per node that BP holds beyond the arrays counted below, found by calibration
#: (tracemalloc's peak and the resident peak, the Motorcycle at x-stripes 78 %, 225×188 to
#: 2048×2048): a 2048×2048 run holds about 235 MiB more than the count and the cache, 9
#: float64 per node, and the process's peak is about 60 MiB above the traced one
_PER_NODE_MARGIN = 16


def bp_memory_estimate(
    shape: tuple[int, int],
    n_unknown: int,
    *,
    k: int = 8,
    neighbourhood: int = 5,
    channels: int = 3,
    n_pairs: int | None = None,
) -> int:
    """An upper bound of the memory, in bytes, that BP needs on an image.

    Parameters
    ----------
    shape : (int, int)
        ``(H, W)`` of the image.
    n_unknown : int
        The number ``N`` of pixels to synthesize (BP's nodes).
    k : int, default 8
        Candidates (labels) per node.
    neighbourhood : int, default 5
        The window side ``n`` of Eq. 2 and Eq. 6.
    channels : int, default 3
        Intensity channels Eq. 2 compares (1 for a grey image or
        ``colour=False``).
    n_pairs : int, optional
        The number ``E`` of pairs of unknown 4-neighbours; default ``2N``, its
        largest possible value.

    Returns
    -------
    int
        Bytes: the arrays BP keeps (image planes, per-node and per-pair
        arrays, the result) plus its largest blocks. Ψ is not included (see
        :func:`psi_bytes`).

    Examples
    --------
    2048×2048 with 80 % unknown fits in 4 GiB (about 3.1 GiB with Ψ's 128 MiB cache; the
    run's resident peak, which ``python benchmarks/bench_speed.py --memory 2048x2048``
    prints, is about 2.9 GiB above the process before it):

    >>> round(bp_memory_estimate((2048, 2048), 3_356_000, n_pairs=6_418_000) / 2**30, 1)
    3.1
    """
    H, W = (int(v) for v in shape)
    n = int(n_unknown)
    e = 2 * n if n_pairs is None else int(n_pairs)
    h = int(neighbourhood) // 2
    pixels = (H + 2 * h) * (W + 2 * h)
    c = int(channels)
    k = int(k)
    # the search: quantised intensity, its float copy and the patch planes, the
    # self terms; per node its candidates and their distances
    search = _FLOAT * (pixels * (3 * c + 6) + n * (2 * k + 3))
    # the messages and what BP returns: per node the labels, unary terms, beliefs,
    # candidate values and positions; per pair its two messages, the node pairs and
    # the schedule's sources and destinations; per pixel the range patches, masks
    # and the filled range and confidence
    result = _FLOAT * (n * (6 * k + 3) + e * (2 * k + 3) + pixels * 8)
    # the blocks: bounded, and no larger than a few rows of work per node; Ψ's cache, held
    # through the sweeps; the calibrated margin
    blocks = min(_BLOCKS, _FLOAT * 256 * k * (n + 1))
    cache = min(_PSI_CACHE, psi_bytes(e, k))
    return int(max(search, result) + blocks + cache + _FLOAT * _PER_NODE_MARGIN * n)


def psi_bytes(n_pairs: int, k: int = 8) -> int:
    """Bytes of the whole Ψ table, ``E·k²`` float64 (``BPResult.log_psi``).

    Parameters
    ----------
    n_pairs : int
        The number ``E`` of pairs of unknown 4-neighbours.
    k : int, default 8
        Candidates per node.

    Returns
    -------
    int

    Examples
    --------
    >>> psi_bytes(1_000_000) / 1e6
    512.0
    """
    return int(n_pairs) * int(k) * int(k) * _FLOAT


def check_bp_memory(shape: tuple[int, int], n_unknown: int, *, limit: int | None = None,
                    **sizes) -> int:
    """Refuse, before any work, a BP call that would need more than ``limit`` bytes.

    Parameters
    ----------
    shape, n_unknown
        As in :func:`bp_memory_estimate`.
    limit : int, optional
        Bytes; default :data:`BP_MEMORY_LIMIT` (4 GiB).
    **sizes
        ``k``, ``neighbourhood``, ``channels``, ``n_pairs`` of
        :func:`bp_memory_estimate`.

    Returns
    -------
    int
        The estimate, when it is within the limit.

    Raises
    ------
    ValueError
        Naming the size, ``k``, the estimate and the limit.

    Examples
    --------
    >>> check_bp_memory((64, 64), 2000) < 2**30
    True
    >>> check_bp_memory((64, 64), 2000, limit=2**20)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: BP on 64×64 (2000 unknown pixels) with k=8 ... 0.0368 GB, ... of 0.00105 GB; ...
    """
    need = bp_memory_estimate(shape, n_unknown, **sizes)
    limit = BP_MEMORY_LIMIT if limit is None else int(limit)
    if need > limit:
        H, W = (int(v) for v in shape)
        k, n = int(sizes.get("k", 8)), int(sizes.get("neighbourhood", 5))
        raise ValueError(
            f"BP on {W}×{H} ({int(n_unknown)} unknown pixels) with k={k} candidates and "
            f"a {n}×{n} neighbourhood would need about {_gb(need)} GB, more than the "
            f"limit of {_gb(limit)} GB; use a smaller image or fewer candidates (k)")
    return need


def _gb(value: int) -> str:
    """Bytes as GB, with as many decimals as a small limit needs."""
    gb = value / 1e9
    return f"{gb:.1f}" if gb >= 0.1 else f"{gb:.3g}"
