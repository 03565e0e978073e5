"""Non-parametric sampling (NP, §3.2.2, Eqs. 2–5, in the order of §3.2.4, Eqs. 10–12).

Two implementations of one algorithm, read side by side:

- :mod:`refsynth.synthesis.nonparametric.reference`: the paper's steps in the paper's
  order, one voxel at a time, with the paper's readings as its defaults — what a student
  reads beside §3.2 and what a port matches;
- :mod:`refsynth.synthesis.nonparametric.fill`: the fast fill behind
  :func:`refsynth.synthesize` (``method="np"``), which makes every decision of the
  reference, bit for bit, under every reading.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, §3.2.4, Eqs. 2–5, 10–12, doi:10.1007/s11263-007-0108-2.
"""

from refsynth.synthesis.nonparametric.fill import CONFIDENCE_UPDATES, eq5_set, np_fill

__all__ = ["CONFIDENCE_UPDATES", "eq5_set", "np_fill"]
