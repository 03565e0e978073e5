r"""Eq. 6 with the candidates' centres as one more shared pixel (§3.2.3): a departure.

Eq. 6 compares the range two neighbouring nodes' candidate patches give the
pixels they share:

.. math:: \Psi(x_k^l, x_j^m) = \exp\left(-\frac{|d_{jk}^l - d_{kj}^m|^2}{2\sigma_s^2}\right)

refsynth reads ``|d − d'|²`` as the mean square over the shared pixels where
*both* training patches have measured range, and Ψ = 1 where there is none
(:mod:`refsynth.synthesis.belief.model`). A training patch is centred on a
measured pixel but holds range only where the measurement does: on the
Motorcycle's x-stripes (3 known columns between 5 and 17 unknown) two
candidates of neighbouring nodes often share no measured pixel, or one or
two, so Ψ is 1 (the best compatibility) for most label pairs and says little:
BP keeps Eq. 2's first candidate at about 90 % of the nodes.

**This option is not the paper** (``compatibility="overlap-centres"``,
:func:`refsynth.synthesize`, BP only). The two candidates' centre ranges — the
range each label gives its own node, always measured — count as one more
shared pixel of the mean square:

.. math:: |d - d'|^2 = \frac{\sum_{v \in S} (d_v - d'_v)^2 + (c^l - c^m)^2}{|S| + 1}

where ``S`` is the shared measured overlap and ``c^l``, ``c^m`` the centre
ranges of the two labels (for a measured neighbour, its own range). With an
empty overlap Ψ compares the two nodes' ranges, a smoothness term of
neighbouring values; with a full overlap the centres weigh one pixel in
``n(n − 1) + 1``. It stays exact: the centres are on the same ``2**-16`` grid
as the overlap, and the sum is of integers
(:func:`refsynth.synthesis.belief.model.pair_compatibilities`,
:func:`~refsynth.synthesis.belief.model.fixed_neighbour_terms`,
:class:`~refsynth.synthesis.belief.model.Compatibilities`, all with ``centres``).

Measured (MAR in disparity px, the Motorcycle's x-stripes at 63 / 78 / 85 %,
``audit_departures.py --variants bp-fig6,bp-centres,bp-centres-sigma-s0.1 --seeds 0``):
on the choosing split (450×375, stripe phase 1) 0.317 / 0.592 / 0.824 against
Fig. 6's 0.328 / 0.597 / 0.848 (with σ_s = 0.1: 0.309 / 0.582 / 0.821), a gain
of 3 % or less at 78 and 85 %, a tie by the audit's rule; on the report split
0.353 / 0.553 / 0.791 (450×375) and 0.323 / 0.579 / 0.904 (741×500) against
0.353 / 0.570 / 0.809 and 0.333 / 0.600 / 0.932; on the room (grids 10/20,
5/25) 0.242 / 0.302 m against 0.244 / 0.312. With the observations completed
(:mod:`refsynth.synthesis.belief.observation`) it adds 1–4 %.

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Eq. 6, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from refsynth.synthesis.belief.model import COMPATIBILITIES

__all__ = ["COMPATIBILITIES"]
