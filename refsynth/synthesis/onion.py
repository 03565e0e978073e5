r"""The onion-peel order (§3.2.4, Fig. 7): layer by layer from the known region inwards.

The order the paper compares its priority order (Eqs. 10–12,
:mod:`refsynth.synthesis.priority`) against: the unknown voxels are filled in
layers of growing chessboard distance to the measured range, fixed before
synthesis starts. NP (:mod:`refsynth.synthesis.nonparametric`) follows this
schedule with ``ordering="onion"``.

References
----------
Torres-Méndez & Dudek (2008), §3.2.4, Fig. 7, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

__all__ = ["onion_order"]


def onion_order(known: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The onion-peel order (Fig. 7): layer by layer from the known region inwards.

    A pixel's layer is its chessboard distance to the nearest known pixel; the
    schedule is fixed before synthesis starts. Within a layer the order is a
    seeded random permutation.

    Parameters
    ----------
    known : ndarray of shape (H, W), bool
        Where the range was measured.
    rng : numpy.random.Generator
        Orders the pixels within a layer.

    Returns
    -------
    ndarray of shape (N,)
        Flat indices of the unknown pixels, in fill order.

    Examples
    --------
    >>> import numpy as np
    >>> known = np.zeros((1, 4), dtype=bool); known[0, 0] = True
    >>> onion_order(known, np.random.default_rng(0)).tolist()
    [1, 2, 3]
    """
    layer = ndimage.distance_transform_cdt(~known, metric="chessboard")
    unknown = np.flatnonzero(~known)
    tie = rng.permutation(unknown.size)
    return unknown[np.lexsort((tie, layer.ravel()[unknown]))]
