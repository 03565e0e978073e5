r"""The fill order's priority queue (§3.2.4): the next front voxel in a few numpy calls.

:class:`refsynth.synthesis.priority.FillFront` takes, at every step of the
sequential fill, the front voxel that comes first in the order

.. math:: (\text{tier} \uparrow,\ P(V_p) \downarrow,\ \text{tie} \uparrow)

(Eq. 10's priority within the tier, ties broken by a seeded permutation of
the pixels). :class:`FrontQueue` keeps that set without a binary heap (whose
stale entries made most of the work): every pixel holds one 64-bit integer
key that sorts exactly as (tier, priority) — :func:`encode_keys` — and the
keys are *stored in tie order*, pixel ``x`` at slot ``tie[x]``. The first
maximum of the key array is then the pixel the order names, since numpy's
``argmax`` returns the first of equal maxima. The array is cut into blocks,
each with an upper bound of its keys, so a pop is two ``argmax`` over short
arrays. An update raises the bounds of the blocks it touched (one
``numpy.maximum.at``) and never lowers them; a pop takes the first block of the
largest bound and, if that bound is looser than the block's maximum (a key
there was lowered or removed), tightens it and looks again. Every other block's
maximum is at most its bound, so the block a pop settles on holds the first
maximum of the whole array. (About one pop in 200 looks twice on the
Motorcycle.)

The keys
--------
A priority is a positive, finite float64 (Eq. 10: ``C · D ≥ 0`` plus
``1 / (1 + E) > 0``), and the IEEE bit patterns of positive doubles, read as
integers, sort as the doubles do (and equal doubles have equal bits), so
``key = bits(P)`` in tier 0 and ``bits(P) − 2**63`` in tier 1 puts every
tier-0 pixel above every tier-1 pixel and keeps the order within a tier
exactly. Pixels off the front hold ``−2**63``, below every key.

References
----------
Torres-Méndez & Dudek (2008), §3.2.4, Eq. 10, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ABSENT", "encode_keys", "FrontQueue"]

#: The key of a pixel that is not in the queue (below every encoded key).
ABSENT = np.iinfo(np.int64).min


def encode_keys(priority: np.ndarray, tier: np.ndarray | None = None) -> np.ndarray:
    """Integer keys that sort as ``(tier ascending, priority descending)`` would pop.

    Parameters
    ----------
    priority : ndarray of float64
        Positive, finite priorities (Eq. 10).
    tier : ndarray of int or bool, optional
        0 or 1 per priority (1: taken only when no tier-0 voxel is left);
        default all 0.

    Returns
    -------
    ndarray of int64
        A larger key comes first; equal keys exactly where tier and priority are equal.

    Examples
    --------
    >>> import numpy as np
    >>> keys = encode_keys(np.array([0.5, 1.5, 1.5, 2.0]), np.array([0, 0, 0, 1]))
    >>> np.argsort(-keys, kind="stable").tolist()
    [1, 2, 0, 3]
    """
    keys = np.ascontiguousarray(priority, dtype=np.float64).view(np.int64)
    if tier is None:
        return keys.copy()
    return keys + np.where(np.asarray(tier) != 0, ABSENT, 0)


class FrontQueue:
    """A set of pixels with integer keys: pop the largest key, ties to the smallest ``tie``.

    Parameters
    ----------
    tie : ndarray of int, shape (N,)
        A permutation of ``range(N)``: pixel ``x``'s rank among equal keys.
    block : int, optional
        Length of the blocks whose maxima are kept; default about
        ``sqrt(N) / 2``, a power of two, at least 8 (an update touches a few
        dozen blocks, a pop scans ``N / block`` maxima and two blocks). Replaying
        NP's queue on the Motorcycle (``python benchmarks/bench_queue.py``), blocks
        of 32 to 512 cost the same at 112×94, and at 900×750 blocks of 512 took
        3.9 µs a step, of 64 (``sqrt(N) / 10``) 4.6.

    Examples
    --------
    >>> import numpy as np
    >>> queue = FrontQueue(np.array([3, 0, 2, 1]))
    >>> queue.set(np.array([0, 1, 2]), encode_keys(np.array([1.0, 2.0, 2.0])))
    >>> [queue.pop() for _ in range(4)]   # pixel 1 has the smaller tie of the two 2.0s
    [1, 2, 0, -1]
    """

    def __init__(self, tie: np.ndarray, block: int | None = None) -> None:
        tie = np.asarray(tie, dtype=np.int64).ravel()
        size = tie.size
        if block is None:
            block = 1 << max(3, int(round(np.log2(max(size, 1) / 4.0) / 2.0)))
        self.shift = int(block).bit_length() - 1
        self.block = 1 << self.shift
        blocks = -(-max(size, 1) // self.block)
        self.rank = tie
        # pixel of each slot, read one at a time (int32 where it holds: half the memory)
        index = np.int32 if size < 2**31 else np.int64
        self.pixel_at = np.empty(blocks * self.block, dtype=index)
        self.pixel_at[tie] = np.arange(size)
        self.keys = np.full(blocks * self.block, ABSENT, dtype=np.int64)
        self.blocks = self.keys.reshape(blocks, self.block)
        self.maxima = np.full(blocks, ABSENT, dtype=np.int64)
        self.retries = 0  # bounds pop found loose and tightened (a diagnostic)
        # pop's single values through memoryviews (Python ints, cheaper than numpy scalars)
        self._keys_mv, self._maxima_mv, self._pixel_mv = (
            memoryview(a) for a in (self.keys, self.maxima, self.pixel_at))

    def set(self, pixels: np.ndarray, keys: np.ndarray) -> None:
        """Give ``pixels`` the ``keys`` (``ABSENT`` removes a pixel).

        Parameters
        ----------
        pixels : ndarray of int
            Pixel indices (any shape).
        keys : ndarray of int64
            Their keys (:func:`encode_keys`), same shape.

        Examples
        --------
        >>> import numpy as np
        >>> queue = FrontQueue(np.arange(3))
        >>> queue.set(np.array([0, 2]), encode_keys(np.array([1.0, 3.0])))
        >>> queue.set(np.array([2]), np.array([ABSENT]))
        >>> queue.pop(), queue.pop()
        (0, -1)
        """
        self.set_slots(self.rank[pixels], keys)

    def set_slots(self, slots: np.ndarray, keys: np.ndarray) -> None:
        """:meth:`set` by slot (``tie[pixel]``) rather than by pixel.

        Parameters
        ----------
        slots : ndarray of int
            ``tie`` of the pixels (any shape).
        keys : ndarray of int64
            Their keys, same shape.

        Examples
        --------
        >>> import numpy as np
        >>> queue = FrontQueue(np.array([1, 0]))
        >>> queue.set_slots(np.array([1]), encode_keys(np.array([1.0])))   # pixel 0
        >>> queue.pop()
        0
        """
        slots = np.ravel(slots)
        # many slots at once (the whole front, at the start): each touched block's maximum
        # once, from the block itself; set_in_blocks gathers a block per slot, which for
        # half a million slots in blocks of 256 would be a gigabyte
        self.keys[slots] = np.ravel(keys)
        touched = np.unique(slots >> self.shift)
        self.maxima[touched] = self.blocks[touched].max(axis=1)

    def set_in_blocks(self, slots: np.ndarray, blocks: np.ndarray, keys: np.ndarray) -> None:
        """:meth:`set_slots` given also the slots' blocks, ``slots >> shift``: raises their bounds.

        A lowered key leaves its block's bound loose; :meth:`pop` tightens it when it
        meets it.

        Parameters
        ----------
        slots : ndarray of int
            ``tie`` of the pixels (any shape).
        blocks : ndarray of int
            ``slots >> self.shift``, same shape.
        keys : ndarray of int64
            Their keys, same shape.

        Examples
        --------
        >>> import numpy as np
        >>> queue = FrontQueue(np.arange(20), block=8)
        >>> slots = np.array([3, 17])
        >>> queue.set_in_blocks(slots, slots >> queue.shift, encode_keys(np.array([1.0, 2.0])))
        >>> queue.pop(), queue.pop()
        (17, 3)
        """
        self.keys[slots] = keys
        # raised where a key passes its block's bound; a lowered key leaves the bound above
        # the block's maximum, which pop tightens when it meets it
        np.maximum.at(self.maxima, blocks, keys)

    def pop(self) -> int:
        """Remove and return the pixel with the largest key (the smallest tie among equals).

        Returns
        -------
        int
            The pixel index, or -1 when the queue is empty.

        Examples
        --------
        >>> import numpy as np
        >>> queue = FrontQueue(np.array([1, 0]))
        >>> queue.set(np.array([0, 1]), encode_keys(np.array([1.0, 1.0])))
        >>> queue.pop(), queue.pop(), queue.pop()
        (1, 0, -1)
        """
        keys, maxima = self._keys_mv, self._maxima_mv
        while True:
            b = int(self.maxima.argmax())
            row = self.blocks[b]
            start = b << self.shift
            slot = start + int(row.argmax())
            if keys[slot] == maxima[b]:  # the bound is the block's maximum
                break
            maxima[b] = keys[slot]  # tightened: the first bound may now be another block's
            self.retries += 1
        if keys[slot] == ABSENT:
            return -1
        keys[slot] = ABSENT
        # the block's new maximum (argmax: cheaper than max)
        self._maxima_mv[b] = keys[start + int(row.argmax())]
        return self._pixel_mv[slot]
