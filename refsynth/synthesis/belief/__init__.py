"""Belief propagation (§3.2.3, Fig. 6): the literal reference, the paper as printed.

:func:`~refsynth.synthesis.belief.reference.bp_reference` runs Fig. 6's steps in the paper's
order with the paper's readings as its defaults; :func:`refsynth.synthesize` with
``method="bp"`` and the paper's options gives the same bits.
"""

from refsynth.synthesis.belief.reference import BeliefReference, bp_reference

__all__ = ["BeliefReference", "bp_reference"]
