r"""The readings of the paper, as presets: ``"paper"`` (as printed) and ``"refsynth"`` (measured).

Where §3.2 leaves a choice open, or where refsynth departs from it because the departure
won on real data, the choice is a *reading*: one field of :class:`Readings`.
:func:`refsynth.synthesize` takes them together as ``readings=``:

- ``readings="refsynth"`` (the default): refsynth's measured readings, each departure
  chosen on the Motorcycle (the README's departures section and audit);
- ``readings="paper"``: the paper as printed — Eq. 2 as written, Eq. 5's value copy,
  Fig. 6's observations, training disc and labels;
- a mapping of overrides on the default preset, ``readings={"range_copy": "value"}``,
  to turn one departure off (or on) by name;
- a :class:`Readings`, e.g. ``Readings.paper().replace(range_copy="offset")``.

Every field is checked when a :class:`Readings` is made (a bad value raises ``ValueError``
or ``TypeError`` naming the field); an unknown name raises ``ValueError`` naming it and
listing the valid ones, before any work.

The fields, the paper's text, the two presets and the evidence
----------------------------------------------------------------

======================  =============  =============  ============================================
field                   ``paper``      ``refsynth``   the paper's text; the evidence for
                                                      refsynth's value
======================  =============  =============  ============================================
``range_weight``        1              1              Eq. 2 adds the intensity and range terms
                                                      with no weight (λ = 1 on the normalised
                                                      terms); λ = 16 lost on the Motorcycle at
                                                      every fraction.
``missing_range``       ``ignore``     ``mean``       Eq. 2 sums over the data both neighbourhoods
                                                      have; charging the target's other offsets
                                                      the mean shared discrepancy won at 63 and 85
                                                      %.
``colour``              True           True           Eq. 2's ``I`` is "grayscale or color"; the
                                                      Middlebury images are colour (§3.3).
``channels``            ``sum``        ``sum``        Eq. 2's intensity term over the channels:
                                                      their sum as written (the mean lost at every
                                                      fraction).
``range_copy``          ``value``      ``offset``     Eq. 5: "R_q is then used to specify R_p";
                                                      Fig. 6, step 6: the centre pixel's depth.
                                                      The shifted copy won at every fraction and
                                                      size, NP and BP.
``confidence_update``   ``best``       ``best``       After Eq. 11: "the confidence of the
                                                      augmented voxel which most resemble the
                                                      neighborhood of V_p is assigned to C(V_p)".
``edges_last``          True           True           §3.2.4: voxels on an edge are deferred "to
                                                      the very end" (read on the fill front).
``observation``         ``measured``   ``np``         Fig. 6, step 1: the patches of the
                                                      registered intensity and *incomplete* range;
                                                      completing them by NP's fill won at every
                                                      fraction.
``training_radius``     ``fixed``      ``gap``        Fig. 6, step 2: "the local training set
                                                      located up to distance r"; the disc widened
                                                      by the gap's depth pays with the completed
                                                      observations.
``compatibility``       ``overlap``    ``overlap``    Eq. 6: the pixels of the two candidates in
                                                      their overlap (``overlap-centres`` tied).
``proximity``           0              0              Fig. 6, step 2 ranks by the patches' match
                                                      alone (a spatial prior lost at every
                                                      fraction).
``sigma_i``             0.1            0.1            Eq. 7's σ_i: "parameters of the algorithm",
                                                      no value given (a factor of 2 moves MAR <
                                                      1.5 %).
``sigma_s``             0.2            0.2            Eq. 6's σ_s: as σ_i.
``product``             ``max``        ``max``        Eq. 8's MAP estimate; Eq. 9's operator is
                                                      lost in the text: max-product, as Freeman et
                                                      al. 2000.
``tolerance``           0              1e-4           §3.3: 50 iterations, no stopping rule; 0
                                                      stops only at an exact fixed point, where
                                                      further sweeps change nothing.
``edge_rule``           ``silent``     ``silent``     §3.2.3: a node sends once it has heard from
                                                      all its other neighbours "except those edge-
                                                      labeled nodes" — edge nodes send nothing
                                                      (``deaf``: they receive nothing either,
                                                      EQUATIONS.md's reading; the two tied).
``offset_tolerance``    None           None           BP's agreement for the shifted labels (no
                                                      paper text: ``range_copy="offset"`` only);
                                                      None: by the observation, ``2**-3`` on NP's
                                                      fill, else ``2**-7``.
``proposals``           None           None           Fig. 6's candidates are the training patches
                                                      only; NP's fills as more labels lost at 63
                                                      %.
``proposal_runs``       1              1              The NP fills that propose (with
                                                      ``proposals``).
``gaps``                ``copy``       ``gate``       §3.1.1's slices leave gaps between scanned
                                                      columns; the paper keeps what NP or BP
                                                      copied. The gate (the line across a smooth
                                                      gap, the copy clipped to the bounds across
                                                      a depth edge) won on every scene type
                                                      (``benchmarks/bench_gaps.py``).
``median``              0              3              §3.2 leaves each pixel as NP or BP filled
                                                      it; the 3 × 3 median of the result on the
                                                      synthesized pixels won on every real scene
                                                      × sampling (``benchmarks/bench_gaps.py``)
                                                      and tied on the synthetic room.
``window``              ``fixed``      ``gaps``       §3.3: "windows of 5 × 5 pixels, unless
                                                      otherwise indicated"; Fig. 11's sparsest
                                                      case takes 3 × 3. 3 × 3 on a column scan
                                                      whose gaps are at most 5 columns wide won
                                                      on Fig. 2's slices and 63 % stripes
                                                      (``benchmarks/bench_gaps.py --windows``).
======================  =============  =============  ============================================

The figures behind each line are on the documentation's departures page and in the docstring
of the module that implements the departure (:mod:`refsynth.synthesis.similarity`,
:mod:`refsynth.synthesis.range_copy`, :mod:`refsynth.synthesis.belief.observation`,
:mod:`refsynth.synthesis.belief.gap_radius`, :mod:`refsynth.synthesis.belief.centres`,
:mod:`refsynth.synthesis.belief.proposals`, :mod:`refsynth.synthesis.gap_readings`,
:mod:`refsynth.synthesis.median_pass`, :mod:`refsynth.synthesis.window_reading`), each with
the command that prints them.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2–§3.2.4, Eqs. 2–12, Fig. 6, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields

from refsynth._checks import check_bool, check_choice, check_in_range, check_int, check_real
from refsynth.synthesis.belief.centres import COMPATIBILITIES
from refsynth.synthesis.belief.fill import EDGE_RULES
from refsynth.synthesis.belief.gap_radius import TRAINING_RADII
from refsynth.synthesis.belief.observation import OBSERVATIONS
from refsynth.synthesis.belief.proposals import PROPOSALS
from refsynth.synthesis.gap_readings import GAPS
from refsynth.synthesis.limits import PARAMETER_BOUNDS
from refsynth.synthesis.median_pass import DEFAULT_MEDIAN, check_median
from refsynth.synthesis.nonparametric import CONFIDENCE_UPDATES
from refsynth.synthesis.range_copy import RANGE_COPIES, check_offset_tolerance
from refsynth.synthesis.similarity import CHANNELS, MISSING_RANGE
from refsynth.synthesis.window_reading import WINDOWS

__all__ = ["Readings", "PRESETS", "DEFAULT_PRESET", "NP_READINGS", "BP_READINGS",
           "resolve_readings", "split_options"]

#: Messages of Eq. 9: max-product (MAP) or sum-product.
PRODUCTS = ("max", "sum")

#: The readings NP uses (§3.2.2, §3.2.4).
NP_READINGS = ("range_weight", "missing_range", "colour", "channels", "range_copy",
               "confidence_update", "edges_last", "gaps", "median", "window")
#: The readings BP uses (§3.2.3, Fig. 6): Eq. 2's ranking shares NP's Eq. 2 readings.
BP_READINGS = ("range_weight", "missing_range", "colour", "channels", "range_copy",
               "observation", "training_radius", "compatibility", "proximity", "sigma_i",
               "sigma_s", "product", "tolerance", "edge_rule", "offset_tolerance", "proposals",
               "proposal_runs", "gaps", "median", "window")


def _bounded(name: str, value) -> float:
    low, high = PARAMETER_BOUNDS[name]
    return check_in_range(name, value, low=low, high=high)


def _proposal_runs(value) -> int:
    value = check_int("proposal_runs", value)
    if value < 1:
        raise ValueError(f"The parameter `proposal_runs` must be >= 1, got {value}")
    return value


#: How each field is checked (and normalised: a NumPy scalar becomes a Python one).
_CHECKS = {
    "range_weight": lambda v: _bounded("range_weight", v),
    "missing_range": lambda v: check_choice("missing_range", v, MISSING_RANGE),
    "colour": lambda v: check_bool("colour", v),
    "channels": lambda v: check_choice("channels", v, CHANNELS),
    "range_copy": lambda v: check_choice("range_copy", v, RANGE_COPIES),
    "confidence_update": lambda v: check_choice("confidence_update", v, CONFIDENCE_UPDATES),
    "edges_last": lambda v: check_bool("edges_last", v),
    "observation": lambda v: check_choice("observation", v, OBSERVATIONS),
    "training_radius": lambda v: check_choice("training_radius", v, TRAINING_RADII),
    "compatibility": lambda v: check_choice("compatibility", v, COMPATIBILITIES),
    "proximity": lambda v: _bounded("proximity", v),
    "sigma_i": lambda v: _bounded("sigma_i", v),
    "sigma_s": lambda v: _bounded("sigma_s", v),
    "product": lambda v: check_choice("product", v, PRODUCTS),
    "tolerance": lambda v: check_real("tolerance", v, minimum=0.0),
    "edge_rule": lambda v: check_choice("edge_rule", v, EDGE_RULES),
    "offset_tolerance": lambda v: None if v is None else check_offset_tolerance(v),
    "proposals": lambda v: None if v is None else check_choice("proposals", v, PROPOSALS),
    "proposal_runs": _proposal_runs,
    "gaps": lambda v: check_choice("gaps", v, GAPS),
    "median": check_median,
    "window": lambda v: check_choice("window", v, WINDOWS),
}


@dataclass(frozen=True)
class Readings:
    """Every reading of §3.2 that NP and BP take: one field per choice (see the table above).

    The defaults are refsynth's (:meth:`refsynth`); :meth:`paper` is the paper as printed.
    Every field is checked on construction; :meth:`replace` returns a checked copy.

    Examples
    --------
    >>> Readings.paper().range_copy, Readings().range_copy
    ('value', 'offset')
    >>> sorted(Readings().departures())   # refsynth's departures from the paper
    ['gaps', 'median', 'missing_range', 'observation', 'range_copy', 'tolerance', \
'training_radius', 'window']
    >>> Readings.paper().replace(range_copy="offset").range_copy
    'offset'
    >>> Readings().replace(range_cpy="value")
    Traceback (most recent call last):
    ...
    ValueError: Unknown reading `range_cpy`; the readings are: range_weight, missing_range, \
colour, channels, range_copy, confidence_update, edges_last, observation, training_radius, \
compatibility, proximity, sigma_i, sigma_s, product, tolerance, edge_rule, offset_tolerance, \
proposals, proposal_runs, gaps, median, window
    """

    # Eq. 2 (NP, and BP's ranking)
    range_weight: float = 1.0
    missing_range: str = "mean"
    colour: bool = True
    channels: str = "sum"
    # Eq. 5's copy (NP) and Fig. 6, step 6 (BP)
    range_copy: str = "offset"
    # Eqs. 10-11: NP's order
    confidence_update: str = "best"
    edges_last: bool = True
    # Fig. 6, steps 1-2: BP's observations and training set
    observation: str = "np"
    training_radius: str = "gap"
    # Eqs. 6-9: BP's model and messages
    compatibility: str = "overlap"
    proximity: float = 0.0
    sigma_i: float = 0.1
    sigma_s: float = 0.2
    product: str = "max"
    tolerance: float = 1e-4
    edge_rule: str = "silent"
    offset_tolerance: float | None = None
    proposals: str | None = None
    proposal_runs: int = 1
    # after the fill (NP and BP): a column scan's gaps (refsynth.synthesis.gap_readings)
    gaps: str = "gate"
    # after the gaps (NP and BP): a median of the synthesized pixels (synthesis.median_pass)
    median: int = DEFAULT_MEDIAN
    # the neighbourhood's side when synthesize() is given none (synthesis.window_reading)
    window: str = "gaps"

    def __post_init__(self) -> None:
        for name, check in _CHECKS.items():
            object.__setattr__(self, name, check(getattr(self, name)))
        if self.proposals is None and self.proposal_runs != 1:
            raise ValueError("The reading `proposal_runs` needs `proposals` (e.g. 'np'); "
                             "without it BP has no proposals to run")

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The fields, in the order of the table above."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def refsynth(cls) -> Readings:
        """refsynth's measured readings (the default preset)."""
        return cls()

    @classmethod
    def paper(cls) -> Readings:
        """The paper as printed: Eq. 2 as written, Eq. 5's value copy, Fig. 6's BP, 50 sweeps,
        every pixel as filled, the 5 × 5 window on every sampling."""
        return cls(missing_range="ignore", range_copy="value", observation="measured",
                   training_radius="fixed", tolerance=0.0, gaps="copy", median=0,
                   window="fixed")

    @classmethod
    def preset(cls, name: str) -> Readings:
        """The preset called ``name`` (:data:`PRESETS`)."""
        return PRESETS[check_choice("readings", name, tuple(PRESETS))]()

    def replace(self, **changes) -> Readings:
        """A copy with ``changes`` applied and checked; an unknown name raises ``ValueError``."""
        _check_names(changes)
        values = {name: getattr(self, name) for name in self.names()}
        return Readings(**{**values, **changes})

    def as_dict(self) -> dict:
        """The fields as a plain dict, in table order."""
        return {name: getattr(self, name) for name in self.names()}

    def departures(self, base: str = "paper") -> dict:
        """The fields that differ from the preset ``base``, with their values here."""
        other = Readings.preset(base)
        return {name: value for name, value in self.as_dict().items()
                if value != getattr(other, name)}

    def for_method(self, method: str) -> dict:
        """The readings that ``method`` (``"np"`` or ``"bp"``) uses, as a dict."""
        used = NP_READINGS if method == "np" else BP_READINGS
        return {name: getattr(self, name) for name in used}


#: The named presets.
PRESETS = {"refsynth": Readings.refsynth, "paper": Readings.paper}
#: The preset :func:`refsynth.synthesize` uses when it is given none.
DEFAULT_PRESET = "refsynth"


def _check_names(names) -> None:
    valid = Readings.names()
    for name in names:
        if name not in valid:
            raise ValueError(f"Unknown reading `{name}`; the readings are: {', '.join(valid)}")


def resolve_readings(readings, method: str = "np") -> Readings:
    """``readings=`` of :func:`refsynth.synthesize` as a checked :class:`Readings`.

    Parameters
    ----------
    readings : str, Readings or mapping
        A preset's name (:data:`PRESETS`), a :class:`Readings`, or a mapping of overrides
        applied on the default preset (``None`` in it: the default's value). In a mapping, a
        reading that ``method`` does not use raises ``ValueError`` unless it is the
        default's value (a BP reading given to NP would change nothing).
    method : {"np", "bp"}
        The method that will use them.

    Examples
    --------
    >>> resolve_readings("paper").observation
    'measured'
    >>> resolve_readings({"range_copy": "value"}).missing_range
    'mean'
    >>> resolve_readings({"observation": "measured"}, "np")
    Traceback (most recent call last):
    ...
    ValueError: The reading `observation` applies to method='bp' only; method='np' does not use it
    """
    if isinstance(readings, Readings):
        return readings
    if isinstance(readings, str):
        return Readings.preset(readings)
    if isinstance(readings, Mapping):
        _check_names(readings)
        changes = {name: value for name, value in readings.items() if value is not None}
        resolved = Readings.preset(DEFAULT_PRESET).replace(**changes)
        default = Readings.preset(DEFAULT_PRESET)
        used = NP_READINGS if method == "np" else BP_READINGS
        for name in changes:
            if name not in used and getattr(resolved, name) != getattr(default, name):
                other = "bp" if method == "np" else "np"
                raise ValueError(f"The reading `{name}` applies to method={other!r} only; "
                                 f"method={method!r} does not use it")
        return resolved
    raise TypeError("The parameter `readings` must be a preset's name "
                    f"({', '.join(map(repr, PRESETS))}), a Readings or a mapping of readings, "
                    f"got {type(readings).__name__}")


def split_options(options: Mapping) -> tuple[dict, dict]:
    """Flat options → ``(keywords of synthesize, readings overrides)``.

    For callers that keep one flat dict of options per run (a table of variants, a
    command line): the names of :class:`Readings` go into the second dict, to be passed as
    ``readings=``; the rest are :func:`refsynth.synthesize`'s own keywords. A ``None``
    reading means its default and is dropped.

    >>> split_options({"method": "bp", "observation": "measured", "seed": 3})
    ({'method': 'bp', 'seed': 3}, {'observation': 'measured'})
    """
    names = set(Readings.names())
    keywords = {k: v for k, v in options.items() if k not in names}
    readings = {k: v for k, v in options.items() if k in names and v is not None}
    return keywords, readings
