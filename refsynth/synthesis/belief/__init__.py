"""Belief propagation (BP, §3.2.3, Eqs. 6–9, Fig. 6): the literal reference and the fast fill.

Two implementations of one algorithm, read side by side:

- :mod:`refsynth.synthesis.belief.reference`: Fig. 6's steps in the paper's order, with the
  paper's readings as its defaults — what a student reads beside §3.2.3 and what a port
  matches (:func:`~refsynth.synthesis.belief.reference.bp_reference`);
- :mod:`refsynth.synthesis.belief.fill`: the fast fill behind :func:`refsynth.synthesize`
  (``method="bp"``), which gives the reference's numbers, bit for bit, under every reading.
  Its steps live beside it: the candidate search (:mod:`~refsynth.synthesis.belief.search`,
  ranked by :mod:`~refsynth.synthesis.belief.ranking`), Φ, Ψ and the grid
  (:mod:`~refsynth.synthesis.belief.model`), the messages of Eq. 9
  (:mod:`~refsynth.synthesis.belief.messages`) and the memory estimate
  (:mod:`~refsynth.synthesis.belief.memory`); refsynth's departures, each applicable to the
  reference too: the observations (:mod:`~refsynth.synthesis.belief.observation`), the gap
  radius (:mod:`~refsynth.synthesis.belief.gap_radius`), the compatibility's centres
  (:mod:`~refsynth.synthesis.belief.centres`) and the proposals
  (:mod:`~refsynth.synthesis.belief.proposals`).

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Eqs. 6–9, Fig. 6, doi:10.1007/s11263-007-0108-2.
"""

from refsynth.synthesis.belief.reference import BeliefReference, bp_reference

__all__ = ["BeliefReference", "bp_reference"]
