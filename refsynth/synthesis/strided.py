"""Views of a frame-shaped array that NP's per-step code indexes once (§3.2.2, Eqs. 10–12).

:class:`refsynth.synthesis.priority.FillFront` reaches a pixel's state, and the block of
state around it, by one integer index per step instead of slicing: the frame's two pixel
axes merged (:func:`flat_view`), and every ``side × side`` block as one strided view
(:func:`block_views`). Both are views: writing through them writes the frame.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import as_strided

__all__ = ["flat_view", "block_views"]


def flat_view(array: np.ndarray) -> np.ndarray:
    """``array`` with its two pixel axes merged, a view (never a copy).

    Examples
    --------
    >>> frame = np.arange(12).reshape(3, 4)
    >>> flat = flat_view(frame); flat[5] = -1
    >>> int(frame[1, 1])
    -1
    """
    flat = array.view()
    flat.shape = (array.shape[0] * array.shape[1],) + array.shape[2:]  # raises if a copy
    return flat


def block_views(array: np.ndarray, side: int) -> tuple[int, np.ndarray]:
    """Every ``side × side`` block of a frame-shaped array, as one strided view.

    Returns ``(offset, view)``: ``view[p - offset]`` is the block of ``array`` (a view into
    it, writeable) centred on the flat pixel ``p``, for every ``p`` whose block lies in the
    frame.

    Examples
    --------
    >>> frame = np.arange(20).reshape(4, 5)
    >>> offset, blocks = block_views(frame, 3)
    >>> p = 1 * 5 + 2   # the pixel (1, 2)
    >>> blocks[p - offset].tolist()
    [[1, 2, 3], [6, 7, 8], [11, 12, 13]]
    """
    width = array.shape[1]
    offset = (side // 2) * (width + 1)
    flat = flat_view(array)
    step = flat.strides[0]
    return offset, as_strided(flat, shape=(flat.shape[0] - 2 * offset, side, side)
                              + flat.shape[1:], strides=(step, width * step, step)
                              + flat.strides[1:])
