"""The front door's own options, method by method, and their checks (§3.2).

:func:`refsynth.synthesize` takes the paper's parameters as keywords and the readings of the
paper together as ``readings=`` (:mod:`refsynth.synthesis.readings`). Of its keywords, a few
belong to one method (:data:`NP_OPTIONS`, :data:`BP_OPTIONS`): they default to ``None``,
which means the method's default, and giving one to the other method raises ``ValueError``
unless it is that option's default. Every check runs before any work and names the argument.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2–§3.2.4, Fig. 6, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import partial
from types import MappingProxyType

import numpy as np

from refsynth._checks import check_bool, check_choice, check_in_range, check_int, check_seed, is_int
from refsynth.synthesis.limits import PARAMETER_BOUNDS
from refsynth.synthesis.readings import DEFAULT_PRESET, resolve_readings, split_options

__all__ = [
    "METHODS", "ORDERINGS", "NP_OPTIONS", "BP_OPTIONS", "OPTIONS", "OPTION_CHECKS",
    "at_least", "bounded", "check_method_options", "draws_at_random", "random_source",
]

METHODS = ("np", "bp")
ORDERINGS = ("priority", "onion")

#: NP's own keywords, with NP's defaults (Eq. 5's ε, Eq. 12's data term, §3.2.4's order).
NP_OPTIONS = MappingProxyType({
    "epsilon": 0.1,
    "use_isophotes": True,
    "ordering": "priority",
})
#: BP's own keywords, with BP's defaults (Fig. 6's ``k``, §3.3's 50 iterations).
BP_OPTIONS = MappingProxyType({
    "candidates": 8,
    "iterations": 50,
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
    "iterations": partial(at_least, "iterations", minimum=0),
}


def check_method_options(method: str, given: dict) -> dict:
    """The options of ``method``, checked, with its defaults where ``None`` was given.

    Every option given is checked first; an option of the *other* method
    raises ``ValueError`` unless it is that option's default.

    >>> check_method_options("bp", {"epsilon": None, "candidates": 4})
    {'candidates': 4, 'iterations': 50}
    """
    checked = {name: OPTION_CHECKS[name](value) for name, value in given.items()
               if value is not None}
    for other, defaults in OPTIONS.items():
        for name, default in defaults.items():
            if other != method and name in checked and checked[name] != default:
                raise ValueError(
                    f"The parameter `{name}` applies to method={other!r} only; "
                    f"method={method!r} does not use it"
                )
    return {name: checked.get(name, default) for name, default in OPTIONS[method].items()}


def draws_at_random(options: Mapping) -> bool:
    """Whether ``synthesize(..., **options)`` depends on its ``seed``.

    ``options`` holds :func:`refsynth.synthesize`'s keywords, and its readings either as
    ``readings`` or flat (:func:`refsynth.synthesis.readings.split_options`). NP always
    draws (Eq. 5's draw, the fill order's ties); BP when NP runs first: on NP's fill
    (``observation="np"``, the default preset's) or with ``proposals``.

    >>> draws_at_random({}), draws_at_random({"method": "bp"})
    (True, True)
    >>> draws_at_random({"method": "bp", "observation": "colorization"})
    False
    >>> draws_at_random({"method": "bp", "readings": "paper"})
    False
    >>> draws_at_random({"method": "bp", "observation": "measured", "proposals": "np"})
    True
    """
    if options.get("method", "np") == "np":
        return True
    _, flat = split_options(options)
    readings = resolve_readings(options.get("readings", DEFAULT_PRESET), "bp")
    if flat:
        readings = readings.replace(**flat)
    return readings.proposals is not None or readings.observation == "np"


def random_source(seed) -> np.random.Generator:
    """The generator behind every random choice: from an int, a Generator or None."""
    if not (seed is None or is_int(seed) or isinstance(seed, np.random.Generator)):
        raise TypeError(
            "The parameter `seed` must be an int, a numpy Generator or None, "
            f"got {type(seed).__name__}"
        )
    return np.random.default_rng(check_seed(seed))  # a Generator is returned unaltered
