"""The options of :func:`refsynth.synthesize`, method by method, and their checks (§3.2).

Each method has options of its own (:data:`NP_OPTIONS`, :data:`BP_OPTIONS`):
they default to ``None``, which means the method's default, and giving one to
the other method raises ``ValueError`` unless it is that option's default.
BP's readings of Fig. 6's step 2 and Eq. 6 (:data:`BP_DEPARTURES`) and NP's
proposals for BP are checked the same way. Every check runs before any work
and names the argument.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2–§3.2.4, Fig. 6, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from functools import partial
from types import MappingProxyType

import numpy as np

from refsynth._checks import (
    check_bool,
    check_choice,
    check_in_range,
    check_int,
    check_real,
    check_seed,
    is_int,
)
from refsynth.synthesis.bp import EDGE_RULES
from refsynth.synthesis.bp_centres import COMPATIBILITIES
from refsynth.synthesis.bp_gap_radius import TRAINING_RADII
from refsynth.synthesis.bp_observation import OBSERVATIONS
from refsynth.synthesis.bp_proposals import PROPOSALS
from refsynth.synthesis.limits import PARAMETER_BOUNDS
from refsynth.synthesis.nonparametric import CONFIDENCE_UPDATES
from refsynth.synthesis.range_copy import RANGE_COPIES, check_offset_tolerance

__all__ = [
    "METHODS", "PRODUCTS", "ORDERINGS", "NP_OPTIONS", "BP_OPTIONS", "OPTIONS", "BP_DEPARTURES",
    "OPTION_CHECKS", "at_least", "bounded", "check_method_options", "check_proposals",
    "check_bp_departures", "draws_at_random", "random_source",
]

METHODS = ("np", "bp")
PRODUCTS = ("max", "sum")
ORDERINGS = ("priority", "onion")

#: NP's options, with NP's defaults (§3.2.2, §3.2.4); read-only. ``range_copy`` is both
#: methods' (what a pixel gets from its drawn neighbourhood or its MAP label).
NP_OPTIONS = MappingProxyType({
    "epsilon": 0.1,
    "use_isophotes": True,
    "ordering": "priority",
    "confidence_update": "best",
    "edges_last": True,
    "range_copy": "offset",
})
#: BP's options, with BP's defaults (§3.2.3); read-only.
BP_OPTIONS = MappingProxyType({
    "candidates": 8,
    "proximity": 0.0,
    "sigma_i": 0.1,
    "sigma_s": 0.2,
    "iterations": 50,
    "tolerance": 1e-4,
    "product": "max",
    "edge_rule": "silent",
    "range_copy": "offset",
    "offset_tolerance": None,  # by the observation: range_copy.default_offset_tolerance
})
OPTIONS = {"np": NP_OPTIONS, "bp": BP_OPTIONS}



def at_least(name: str, value, minimum: int) -> int:
    """An integer option ``>= minimum`` (the type check of :func:`check_int`)."""
    value = check_int(name, value)
    if value < minimum:
        raise ValueError(f"The parameter `{name}` must be >= {minimum}, got {value}")
    return value


def bounded(name: str):
    """The check of a real parameter within its :data:`PARAMETER_BOUNDS`."""
    return partial(check_in_range, name, low=PARAMETER_BOUNDS[name][0],
                   high=PARAMETER_BOUNDS[name][1])


#: How each method-specific option is checked (when it is given).
OPTION_CHECKS = {
    "epsilon": bounded("epsilon"),
    "use_isophotes": partial(check_bool, "use_isophotes"),
    "ordering": partial(check_choice, "ordering", choices=ORDERINGS),
    "candidates": partial(at_least, "candidates", minimum=1),
    "proximity": bounded("proximity"),
    "sigma_i": bounded("sigma_i"),
    "sigma_s": bounded("sigma_s"),
    "iterations": partial(at_least, "iterations", minimum=0),
    "tolerance": partial(check_real, "tolerance", minimum=0.0),
    "product": partial(check_choice, "product", choices=PRODUCTS),
    "confidence_update": partial(check_choice, "confidence_update", choices=CONFIDENCE_UPDATES),
    "edges_last": partial(check_bool, "edges_last"),
    "range_copy": partial(check_choice, "range_copy", choices=RANGE_COPIES),
    "edge_rule": partial(check_choice, "edge_rule", choices=EDGE_RULES),
    "offset_tolerance": check_offset_tolerance,
}


def check_method_options(method: str, given: dict) -> dict:
    """The options of ``method``, checked, with its defaults where ``None`` was given.

    Every option given is checked first; an option of the *other* method
    raises ``ValueError`` unless it is that option's default.
    """
    checked = {name: OPTION_CHECKS[name](value) for name, value in given.items()
               if value is not None}
    for other, defaults in OPTIONS.items():
        for name, default in defaults.items():
            if (other != method and name in checked and name not in OPTIONS[method]
                    and checked[name] != default):
                raise ValueError(
                    f"The parameter `{name}` applies to method={other!r} only; "
                    f"method={method!r} does not use it"
                )
    return {name: checked.get(name, default) for name, default in OPTIONS[method].items()}


def check_proposals(method: str, proposals, proposal_runs) -> dict:
    """BP's proposals (a departure, :mod:`refsynth.synthesis.bp_proposals`), checked.

    Empty when ``proposals`` is None (the paper's Fig. 6); otherwise ``proposals`` and
    ``proposal_runs``. Both are BP's: ``method="np"`` refuses them.
    """
    if proposals is None:
        if proposal_runs is not None:
            at_least("proposal_runs", proposal_runs, 1)
            raise ValueError("The parameter `proposal_runs` needs `proposals` (e.g. 'np'); "
                             "without it BP has no proposals to run")
        return {}
    proposals = check_choice("proposals", proposals, PROPOSALS)
    runs = 1 if proposal_runs is None else at_least("proposal_runs", proposal_runs, 1)
    if method != "bp":
        raise ValueError(f"The parameter `proposals` applies to method='bp' only; "
                         f"method={method!r} does not use it")
    return {"proposals": proposals, "proposal_runs": runs}


#: BP's readings of Fig. 6, step 2 and Eq. 6 when the caller names none: the observations
#: completed by NP's fill (since 0.9; 0.4–0.8: the colorization fill) and the training disc
#: widened by the gap's depth (departures that won on real data, issue #10; ``"measured"``,
#: ``"fixed"`` are Fig. 6's).
BP_DEPARTURES = MappingProxyType({"observation": "np", "compatibility": "overlap",
                                  "training_radius": "gap"})


def check_bp_departures(method: str, observation, compatibility, training_radius=None) -> dict:
    """BP's readings of Fig. 6, step 2 and Eq. 6 (:data:`BP_DEPARTURES` where None), checked.

    For ``method="bp"`` all three, the defaults filled in; the other methods
    refuse them unless they are None or the default, and get ``{}``.
    """
    given = {}
    if observation is not None:
        given["observation"] = check_choice("observation", observation, OBSERVATIONS)
    if compatibility is not None:
        given["compatibility"] = check_choice("compatibility", compatibility, COMPATIBILITIES)
    if training_radius is not None:
        given["training_radius"] = check_choice("training_radius", training_radius,
                                                TRAINING_RADII)
    if method != "bp":
        for name, value in given.items():
            if value != BP_DEPARTURES[name]:
                raise ValueError(f"The parameter `{name}` applies to method='bp' only; "
                                 f"method={method!r} does not use it")
        return {}
    return {**BP_DEPARTURES, **given}


def draws_at_random(options: dict) -> bool:
    """Whether ``synthesize(..., **options)`` depends on its ``seed``.

    NP always does (Eq. 5's draw, the fill order's ties); BP when NP runs first: on NP's fill
    (``observation="np"``, BP's default since 0.9) or with ``proposals``.

    >>> draws_at_random({}), draws_at_random({"method": "bp"})
    (True, True)
    >>> draws_at_random({"method": "bp", "observation": "colorization"})
    False
    >>> draws_at_random({"method": "bp", "observation": "measured", "proposals": "np"})
    True
    """
    if options.get("method", "np") == "np":
        return True
    return (options.get("proposals") is not None
            or options.get("observation", BP_DEPARTURES["observation"]) == "np")


def random_source(seed) -> np.random.Generator:
    """The generator behind every random choice: from an int, a Generator or None."""
    if not (seed is None or is_int(seed) or isinstance(seed, np.random.Generator)):
        raise TypeError(
            "The parameter `seed` must be an int, a numpy Generator or None, "
            f"got {type(seed).__name__}"
        )
    return np.random.default_rng(check_seed(seed))  # a Generator is returned unaltered
