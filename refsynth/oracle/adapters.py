"""refsynth's own functions in ``oracle check``'s calling convention.

- :func:`refsynth_reference`: the literal reference (and, for the per-equation kinds, the
  functions that wrote the expected values); it passes by construction:
  ``python -m refsynth oracle check refsynth.oracle:refsynth_reference``.
- :func:`refsynth_fast`: the fast code that users run, :func:`refsynth.synthesize` for whole
  NP and BP runs (its outputs and BP's model: candidates, unary terms, compatibilities,
  messages, beliefs), and the fast code's own Eq. 5, 6 and 7
  (:func:`~refsynth.synthesis.nonparametric.eq5_set`,
  :func:`~refsynth.synthesis.belief.fill.pair_compatibilities`,
  :func:`~refsynth.synthesis.belief.fill.psi`, :func:`~refsynth.synthesis.belief.fill.phi`);
  None (skipped) for the other kinds.

Either is also a template for a port's adapter: take ``inputs`` and ``options``, call the
port, return a dict of arrays named as the case's outputs.
"""

from __future__ import annotations

import numpy as np

from refsynth.numeric import NO_RANGE, RANGE_BITS

__all__ = ["refsynth_reference", "refsynth_fast", "BP_MODEL"]

#: The parts of BP's model that :func:`refsynth_fast` returns when the fast code exposes them.
BP_MODEL = ("labels", "candidates", "unary", "pairs", "log_psi", "messages", "beliefs")


def refsynth_reference(inputs: dict, options: dict) -> dict:
    """The literal reference in the checker's convention (it passes by construction).

    Every kind of case is handled: NP and BP runs by
    :mod:`refsynth.synthesis.reference` (from the raw inputs, not the
    prepared arrays), the equations by the functions that wrote their
    expected values (:func:`~refsynth.oracle.cases.expected_outputs`).

    Parameters
    ----------
    inputs : dict of str to ndarray
        The case's ``input`` and ``prepared`` arrays (for a run
        ``intensity`` (H, W) or (H, W, 3), ``partial_range`` (H, W), NaN
        unknown, ``edges`` (H, W) bool, the quantised ``q_intensity`` and
        ``q_range``, the ``window``, NP's random numbers, BP's
        ``q_observation`` and ``sweeps``).
    options : dict
        The case's options (for a run every option of
        :func:`refsynth.synthesize` that the method takes, defaults filled
        in) plus ``method`` (its kind: ``"np"``, ``"eq7"`` …) and ``seed``.

    Returns
    -------
    dict of str to ndarray
        The outputs, prepared arrays and trace, named as the case's.

    Examples
    --------
    Eq. 7, ``log Φ = −d / 2σ_i²`` (§3.2.3):

    >>> options = {"method": "eq7", "seed": None, "sigma_i": 0.5}
    >>> refsynth_reference({"distances": np.array([[0.0, 0.5, 2.0]])}, options)["log_phi"]
    array([[-0., -1., -4.]])
    """
    from refsynth.oracle.cases import Case, expected_outputs

    options = dict(options)
    kind, seed = options.pop("method"), options.pop("seed")
    # a run starts from the raw inputs; an equation case's only prepared array is Eq. 2's window
    names = ("intensity", "partial_range", "edges") if kind in ("np", "bp") else [
        k for k in inputs if k != "window"]
    return expected_outputs(Case("check", kind, {k: inputs[k] for k in names}, options, seed))


def _normalised(q: np.ndarray) -> np.ndarray:
    """Quantised range (−1 unknown) → the normalised floats the fast code takes (NaN unknown)."""
    return np.where(q == NO_RANGE, np.nan, q * 2.0**-RANGE_BITS)


def _fast_equation(kind: str, inputs: dict, options: dict):
    from refsynth.synthesis.belief import fill as bp
    from refsynth.synthesis.nonparametric import eq5_set

    if kind == "eq5":
        d, u = inputs["distances"], inputs["draws"]
        members = np.zeros(d.shape, bool)
        chosen = np.zeros(len(d), np.int64)
        for b, row in enumerate(d):
            gamma = eq5_set(row, options["epsilon"])
            members[b, gamma] = True
            chosen[b] = gamma[int(u[b] * gamma.size)]
        return dict(members=members, chosen=chosen)
    if kind == "eq6":
        first = _normalised(inputs["first"])[:, None]
        second = _normalised(inputs["second"])[:, None]
        ms = bp.pair_compatibilities(first, second, options["direction"])[:, 0, 0]
        return dict(mean_square=ms, log_psi=bp.psi(ms, options["sigma_s"]))
    if kind == "eq7":
        return dict(log_phi=bp.phi(inputs["distances"], options["sigma_i"]))
    return None


def refsynth_fast(inputs: dict, options: dict) -> dict | None:
    """refsynth's fast code in the checker's convention (NP, BP, Eqs. 5–7; else None).

    Whole runs go through :func:`refsynth.synthesize` (with the case's
    ``edges`` unless ``use_edges`` is off); Eqs. 5, 6 and 7 through the fast
    code's :func:`~refsynth.synthesis.nonparametric.eq5_set`,
    :func:`~refsynth.synthesis.belief.fill.pair_compatibilities`,
    :func:`~refsynth.synthesis.belief.fill.psi` and :func:`~refsynth.synthesis.belief.fill.phi`.

    Parameters
    ----------
    inputs : dict of str to ndarray
        The case's ``input`` and ``prepared`` arrays (see
        :func:`refsynth_reference`).
    options : dict
        The case's options plus ``method`` and ``seed``.

    Returns
    -------
    dict of str to ndarray or None
        A run: ``range`` and ``confidence`` (H, W), ``order`` (M, 2) and,
        for BP, the parts of its model in :data:`BP_MODEL`,
        ``candidate_values`` and ``iterations``; an equation: its outputs.
        None for the kinds it does not handle (the checker skips them).

    Examples
    --------
    >>> distances = {"distances": np.array([[0.0, 0.5, 2.0]])}
    >>> refsynth_fast(distances, {"method": "eq7", "seed": None, "sigma_i": 0.5})["log_phi"]
    array([[-0., -1., -4.]])
    >>> refsynth_fast({}, {"method": "eq13", "seed": None}) is None
    True
    """
    import refsynth
    from refsynth.synthesis.readings import split_options

    options = dict(options)
    method = options.pop("method")
    seed = options.pop("seed")
    if method not in ("np", "bp"):
        return _fast_equation(method, inputs, options)
    keywords, readings = split_options(options)
    result = refsynth.synthesize(inputs["intensity"], inputs["partial_range"], method=method,
                                 seed=seed, edges=inputs["edges"] & bool(options["use_edges"]),
                                 **keywords, readings=readings)
    out = dict(range=result.range, confidence=result.confidence, order=result.order)
    model = getattr(result, "bp", None)
    if model is not None:
        for key in BP_MODEL:
            value = getattr(model, key, None)
            if value is not None:
                out[key] = np.asarray(value)
        out["candidate_values"] = np.asarray(model.candidate_values)
        out["iterations"] = np.array(model.iterations)
    return out
