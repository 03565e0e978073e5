"""Range synthesis (§3.2): the dense range from intensity and partial range.

Read beside §3.2 of the paper, top to bottom:

- :mod:`refsynth.synthesis.api`: :func:`synthesize`, the front door —
  validation, edges, dispatch to NP or BP, and which options belong to which
  method.
- :mod:`refsynth.synthesis.readings`: the readings of the paper as presets —
  ``"paper"`` as printed, ``"refsynth"`` (the default) with its measured
  departures — each field with the paper's text and the evidence.
- :mod:`refsynth.synthesis.limits`: the bounds of its parameters — where
  the arithmetic of Eqs. 2–9 stays finite, what the image can use (a radius
  beyond the image is the whole image), the memory a run needs.
- :mod:`refsynth.synthesis.neighbourhood` (§3.2.1, the MRF model): augmented
  voxels, the n×n neighbourhood ``N_p`` and the Gaussian window ``G`` of Eq. 2.
- :mod:`refsynth.synthesis.similarity` (§3.2.2, Eq. 2): the distance between
  two partial neighbourhoods, literally (:func:`eq2_distance`, and
  :func:`neighbourhood_distance` on normalised floats);
  :mod:`refsynth.synthesis.patch_table`: the same, bit for bit, expanded for a
  whole candidate set (:class:`PatchTable`).
- :mod:`refsynth.synthesis.nonparametric` (§3.2.2, Eqs. 3–5 in the order of
  Eqs. 10–12): NP sampling — its literal reference
  (:mod:`~refsynth.synthesis.nonparametric.reference`, the paper's readings as
  its defaults) beside the fast fill (:mod:`~refsynth.synthesis.nonparametric.fill`,
  :func:`np_fill`, and the Eq. 5 set).
- :mod:`refsynth.synthesis.priority` (§3.2.4, Eqs. 10–12): the synthesis
  order — confidence, data term, edge count — and the onion-peel order of
  Fig. 7.
- :mod:`refsynth.synthesis.belief.fill` (§3.2.3, Eqs. 6–7, Fig. 6): belief
  propagation's model — candidates, Φ, Ψ, the edge rule — and :func:`bp_fill`.
- :mod:`refsynth.synthesis.belief.messages` (§3.2.3, Eqs. 8–9): the messages and
  beliefs, :func:`belief_propagation`.
- :mod:`refsynth.synthesis.canny` (§3.2): the Canny edges (σ = 0.8) that
  Eq. 10 and BP's edge-constraint rule use.
- :mod:`refsynth.synthesis.reference` (§3.2.2–§3.2.4): the literal reference of
  NP and BP with refsynth's readings as its defaults, per-pixel loops that the
  fast modules above equal bit for bit under every reading.

Every decision runs on exact numbers, the numeric contract of
:mod:`refsynth.numeric`: the same bits on any machine.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.2, doi:10.1007/s11263-007-0108-2.
"""

from refsynth.synthesis.api import (
    BP_OPTIONS,
    NP_OPTIONS,
    SynthesisResult,
    synthesize,
)
from refsynth.synthesis.belief.fill import *  # noqa: F403 (§3.2.3: the names of bp.__all__)
from refsynth.synthesis.belief.fill import __all__ as _BP_NAMES
from refsynth.synthesis.canny import (
    canny,
    hysteresis,
    non_maximum_suppression,
    sobel_gradients,
    to_grey,
)
from refsynth.synthesis.limits import *  # noqa: F403 (the limits: the names of limits.__all__)
from refsynth.synthesis.limits import __all__ as _LIMIT_NAMES
from refsynth.synthesis.neighbourhood import (
    disc_offsets,
    gaussian_window,
    intensity_patches,
    range_patches,
    window_offsets,
)
from refsynth.synthesis.nonparametric import eq5_set, np_fill
from refsynth.synthesis.patch_table import PatchTable
from refsynth.synthesis.priority import (
    FillFront,
    box_sum,
    confidence_term,
    data_term,
    edge_count,
    fill_front,
    front_normals,
    onion_order,
    priority,
    range_gradient,
)
from refsynth.synthesis.readings import PRESETS, Readings
from refsynth.synthesis.similarity import (
    eq2_distance,
    intensity_scale,
    neighbourhood_distance,
    range_scale,
)

__all__ = [
    # the front door
    "synthesize",
    "SynthesisResult",
    "Readings",
    "PRESETS",
    "NP_OPTIONS",
    "BP_OPTIONS",
    # what it accepts (validate_inputs, normalise_intensity, PARAMETER_BOUNDS, image_reach, ...)
    *_LIMIT_NAMES,
    # §3.2.1: the MRF neighbourhood
    "gaussian_window",
    "window_offsets",
    "disc_offsets",
    "intensity_patches",
    "range_patches",
    # §3.2.2, Eq. 2: literal and expanded
    "neighbourhood_distance",
    "eq2_distance",
    "PatchTable",
    "intensity_scale",
    "range_scale",
    # §3.2.2, Eqs. 3–5: NP
    "eq5_set",
    "np_fill",
    # §3.2.3, Eqs. 6–9: BP (bp_fill, BPResult, candidates, phi, psi, ..., belief_propagation)
    *_BP_NAMES,
    # §3.2.4, Eqs. 10–12: the order
    "priority",
    "confidence_term",
    "data_term",
    "edge_count",
    "range_gradient",
    "front_normals",
    "fill_front",
    "box_sum",
    "onion_order",
    "FillFront",
    # §3.2: Canny
    "canny",
    "to_grey",
    "sobel_gradients",
    "non_maximum_suppression",
    "hysteresis",
]
