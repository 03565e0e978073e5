"""The front door: :func:`synthesize` (§3.2).

Validates the inputs, normalises the intensity, detects intensity edges
(Canny, σ = 0.8) and dispatches to the range-synthesis method. Every other
part of refsynth (the command line, the tutorials, the benchmarks, a faster
port checking itself against this one) calls this function.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.2, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

__all__ = ["SynthesisResult", "synthesize", "normalise_intensity"]

METHODS = ("np", "bp")
PRODUCTS = ("max", "sum")
MISSING_RANGE = ("mean", "ignore")
ORDERINGS = ("priority", "onion")


@dataclass(frozen=True)
class SynthesisResult:
    """What :func:`synthesize` returns.

    Attributes
    ----------
    range : ndarray of shape (H, W), float64
        The dense range, finite everywhere; measured pixels are unchanged.
    confidence : ndarray of shape (H, W), float64
        In [0, 1]: 1 where the range was measured; for NP the confidence the
        pixel received when it was synthesized (Eq. 11, see
        :mod:`refsynth.synthesis.priority`); for BP the normalised belief (Eq. 8) of the
        chosen range, pooled over the candidates that propose it (see
        :mod:`refsynth.synthesis.bp`).
    order : ndarray of shape (N, 2), int64
        The synthesized pixels as (row, col): NP's fill order; for BP, which
        decides all pixels together, raster order.
    edges : ndarray of shape (H, W), bool
        The Canny edge map used (all False when ``use_edges=False``).
    method : str
        ``"np"`` or ``"bp"``.
    params : dict
        The parameters of the run, for provenance.
    iterations : int
        BP's message-passing sweeps (0 for NP).
    candidate_values : ndarray of shape (N, k) or None
        BP: the centre range of each pixel's ``k`` candidates (rows in
        ``order``), to judge candidate generation apart from inference.
    """

    range: np.ndarray
    confidence: np.ndarray
    order: np.ndarray
    edges: np.ndarray
    method: str
    params: dict = field(default_factory=dict)
    iterations: int = 0
    candidate_values: np.ndarray | None = None


def normalise_intensity(intensity: np.ndarray) -> np.ndarray:
    """Return the intensity as float64 of shape (H, W, C).

    Integer images are scaled to [0, 1] by their dtype's maximum; floating
    images are used as given. A grey image gets a trailing channel axis.
    """
    image = np.asarray(intensity)
    if np.issubdtype(image.dtype, np.bool_):
        out = image.astype(np.float64)
    elif np.issubdtype(image.dtype, np.integer):
        out = image.astype(np.float64) / float(np.iinfo(image.dtype).max)
    else:
        out = image.astype(np.float64)
    if out.ndim == 2:
        out = out[:, :, None]
    return out


def _check_int(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"The parameter `{name}` must be an integer, got {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"The parameter `{name}` must be >= {minimum}, got {value}")
    return int(value)


def _check_positive(name: str, value, *, allow_zero: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"The parameter `{name}` must be a real number, got {type(value).__name__}")
    value = float(value)
    if not np.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"The parameter `{name}` must be finite and {bound}, got {value}")
    return value


def validate_inputs(intensity, partial_range) -> tuple[np.ndarray, np.ndarray]:
    """Check ``intensity`` and ``partial_range`` as DESIGN.md specifies.

    Returns the intensity as float64 (H, W, C) and the range as float64 (H, W).
    Raises ``TypeError``/``ValueError`` naming the argument.
    """
    if not isinstance(intensity, np.ndarray):
        raise TypeError(
            f"The parameter `intensity` must be a numpy array, got {type(intensity).__name__}"
        )
    if not isinstance(partial_range, np.ndarray):
        raise TypeError(
            "The parameter `partial_range` must be a numpy array, "
            f"got {type(partial_range).__name__}"
        )
    if not (
        np.issubdtype(intensity.dtype, np.number) or np.issubdtype(intensity.dtype, np.bool_)
    ) or np.issubdtype(intensity.dtype, np.complexfloating):
        raise TypeError(
            f"The parameter `intensity` must have a real numeric dtype, got {intensity.dtype}"
        )
    if not np.issubdtype(partial_range.dtype, np.floating):
        raise TypeError(
            "The parameter `partial_range` must have a floating dtype (NaN marks unknown range), "
            f"got {partial_range.dtype}"
        )
    if intensity.ndim not in (2, 3) or (intensity.ndim == 3 and intensity.shape[2] not in (1, 3)):
        raise ValueError(
            "The parameter `intensity` must be a 2-D grey image (H, W) or a colour image "
            f"(H, W, 3), got shape {intensity.shape}"
        )
    if partial_range.ndim != 2:
        raise ValueError(
            f"The parameter `partial_range` must be a 2-D array, got shape {partial_range.shape}"
        )
    if intensity.shape[:2] != partial_range.shape:
        raise ValueError(
            "The parameters `intensity` and `partial_range` must have the same height and "
            f"width, got {intensity.shape[:2]} and {partial_range.shape}"
        )
    if min(partial_range.shape) < 2:
        raise ValueError(
            f"The parameter `partial_range` must be at least 2x2, got shape {partial_range.shape}"
        )
    image = normalise_intensity(intensity)
    if not np.all(np.isfinite(image)):
        raise ValueError("The parameter `intensity` must be finite everywhere (no NaN or inf)")
    rng_values = partial_range.astype(np.float64)
    if np.any(np.isinf(rng_values)):
        raise ValueError(
            "The parameter `partial_range` must be finite or NaN (NaN = unknown), got inf"
        )
    known = np.isfinite(rng_values)
    if not known.any():
        raise ValueError("The parameter `partial_range` has no known range (all NaN)")
    if known.all():
        raise ValueError("The parameter `partial_range` has nothing to fill (no NaN)")
    return image, rng_values


def synthesize(
    intensity: np.ndarray,
    partial_range: np.ndarray,
    method: str = "np",
    seed: int | np.random.Generator | None = 0,
    *,
    neighbourhood: int = 5,
    radius: float = 10.0,
    epsilon: float = 0.1,
    canny_sigma: float = 0.8,
    edges: np.ndarray | None = None,
    use_edges: bool = True,
    use_isophotes: bool = True,
    ordering: str = "priority",
    range_weight: float = 16.0,
    missing_range: str = "mean",
    candidates: int = 8,
    proximity: float = 1.0,
    sigma_i: float = 0.1,
    sigma_s: float = 0.2,
    iterations: int = 50,
    tolerance: float = 1e-4,
    product: str = "max",
    progress: Callable[[int, int], None] | None = None,
) -> SynthesisResult:
    """Infer the missing range from intensity and partial range (§3.2).

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
        The registered intensity image, grey or colour. Integer images are
        scaled to [0, 1]; floating images are used as given.
    partial_range : ndarray of shape (H, W), floating
        The measured range, NaN where unknown, in any length unit; the
        result comes back in the same unit.
    method : {"np", "bp"}
        Non-parametric sampling (§3.2.2, Eqs. 2–5) or belief propagation
        (§3.2.3, Eqs. 6–9, Fig. 6).
    seed : int, numpy.random.Generator or None
        Source of every random choice (the draw from the Eq. 5 set, ties in
        the fill order). The same seed gives bit-identical output.
    neighbourhood : int, default 5
        Odd side ``n`` of the n×n MRF neighbourhood (§3.2.1).
    radius : float, default 10
        Search radius ``r`` of Eq. 3, in pixels.
    epsilon : float, default 0.1
        Tolerance ε of Eq. 5.
    canny_sigma : float, default 0.8
        σ of the Canny edge detector's Gaussian (the paper's setting).
    edges : ndarray of shape (H, W), bool, optional
        A precomputed edge map; overrides the Canny detector.
    use_edges : bool, default True
        NP: use the edge count of Eq. 10 and fill edge pixels last. BP: the
        edge-constraint rule (edge nodes send no messages). ``False`` is the
        paper's no-edge ablation (Fig. 13, Table 3).
    use_isophotes : bool, default True
        NP: use the isophote data term of Eq. 12. ``False`` sets D = 1 (Fig. 16).
    ordering : {"priority", "onion"}
        NP: the paper's information-driven order (Eqs. 10–12) or the
        onion-peel order it compares against (Fig. 7).
    range_weight : float, default 16
        Weight λ of the range term of Eq. 2 against the intensity term,
        both normalised (see :mod:`refsynth.synthesis.similarity`).
    missing_range : {"mean", "ignore"}
        How Eq. 2's range term treats window offsets where the target has range
        and a candidate has none: ``"mean"`` charges them the mean discrepancy
        of the offsets both have; ``"ignore"`` drops them, the literal Eq. 2
        (see :mod:`refsynth.synthesis.similarity` for why refsynth
        departs from it). BP ranks its candidates with the same distance.
    candidates : int, default 8
        BP: ``k``, the candidates (labels) per unknown pixel.
    proximity : float, default 1
        BP: μ, the weight of the spatial prior ``μ (|p − q| / r)²`` added to
        Eq. 2 when ranking candidates and in Φ (a departure from the paper,
        see :mod:`refsynth.synthesis.bp`); 0 ranks by Eq. 2 alone.
    sigma_i : float, default 0.1
        BP: σ_i of Eq. 7, in units of the Eq. 2 distance's square root.
    sigma_s : float, default 0.2
        BP: σ_s of Eq. 6, in units of the known range's span.
    iterations : int, default 50
        BP: at most this many message-passing sweeps (the paper's 50).
    tolerance : float, default 1e-4
        BP: stop when no (log) message changes by more than this.
    product : {"max", "sum"}
        BP: max-product (MAP, default) or sum-product messages.
    progress : callable, optional
        Called as ``progress(done, total)`` every few hundred pixels.

    Returns
    -------
    SynthesisResult

    Raises
    ------
    TypeError, ValueError
        On bad input, naming the argument, before any work starts.

    Examples
    --------
    >>> import numpy as np, refsynth
    >>> image = np.tile(np.linspace(0, 1, 8), (8, 1))
    >>> partial = np.full((8, 8), np.nan); partial[:, ::3] = 2.0
    >>> result = refsynth.synthesize(image, partial, seed=0)
    >>> bool(np.all(result.range == 2.0))
    True
    """
    image, range_values = validate_inputs(intensity, partial_range)
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"The parameter `method` must be one of {METHODS}, got {method!r}")
    if not isinstance(product, str) or product not in PRODUCTS:
        raise ValueError(f"The parameter `product` must be one of {PRODUCTS}, got {product!r}")
    candidates = _check_int("candidates", candidates, 1)
    iterations = _check_int("iterations", iterations, 0)
    proximity = _check_positive("proximity", proximity, allow_zero=True)
    sigma_i = _check_positive("sigma_i", sigma_i)
    sigma_s = _check_positive("sigma_s", sigma_s)
    tolerance = _check_positive("tolerance", tolerance, allow_zero=True)
    if not isinstance(ordering, str) or ordering not in ORDERINGS:
        raise ValueError(f"The parameter `ordering` must be one of {ORDERINGS}, got {ordering!r}")
    neighbourhood = _check_int("neighbourhood", neighbourhood, 1)
    if neighbourhood % 2 == 0:
        raise ValueError(f"The parameter `neighbourhood` must be odd, got {neighbourhood}")
    radius = _check_positive("radius", radius)
    if radius < 1:
        raise ValueError(f"The parameter `radius` must be >= 1 pixel, got {radius}")
    epsilon = _check_positive("epsilon", epsilon, allow_zero=True)
    canny_sigma = _check_positive("canny_sigma", canny_sigma, allow_zero=True)
    range_weight = _check_positive("range_weight", range_weight, allow_zero=True)
    if not isinstance(missing_range, str) or missing_range not in MISSING_RANGE:
        raise ValueError(
            f"The parameter `missing_range` must be one of {MISSING_RANGE}, got {missing_range!r}"
        )
    for name, flag in (("use_edges", use_edges), ("use_isophotes", use_isophotes)):
        if not isinstance(flag, (bool, np.bool_)):
            raise TypeError(f"The parameter `{name}` must be a bool, got {type(flag).__name__}")
    if edges is not None:
        edges = np.asarray(edges)
        if edges.shape != range_values.shape:
            raise ValueError(
                f"The parameter `edges` must have shape {range_values.shape}, got {edges.shape}"
            )
        if edges.dtype != np.bool_:
            raise TypeError(f"The parameter `edges` must be a boolean array, got {edges.dtype}")
    if progress is not None and not callable(progress):
        raise TypeError("The parameter `progress` must be callable or None")
    if isinstance(seed, np.random.Generator):
        rng = seed
    elif seed is None or (isinstance(seed, (int, np.integer)) and not isinstance(seed, bool)):
        rng = np.random.default_rng(seed)
    else:
        raise TypeError(
            "The parameter `seed` must be an int, a numpy Generator or None, "
            f"got {type(seed).__name__}"
        )

    from refsynth.synthesis.canny import canny, to_grey
    from refsynth.synthesis.nonparametric import np_fill

    if edges is None:
        edge_map = canny(to_grey(image), sigma=canny_sigma) if use_edges else None
    else:
        edge_map = edges.copy()
    if edge_map is None or not use_edges:
        edge_map = np.zeros(range_values.shape, dtype=bool)

    params = dict(
        method=method,
        neighbourhood=neighbourhood,
        radius=radius,
        canny_sigma=canny_sigma,
        use_edges=bool(use_edges),
        range_weight=range_weight,
        missing_range=missing_range,
    )
    if method == "bp":
        from refsynth.synthesis.bp import bp_fill

        params.update(candidates=candidates, proximity=proximity, sigma_i=sigma_i, sigma_s=sigma_s,
                      iterations=iterations, tolerance=tolerance, product=product)
        bp = bp_fill(
            image,
            range_values,
            edge_map,
            neighbourhood=neighbourhood,
            radius=radius,
            k=candidates,
            sigma_i=sigma_i,
            sigma_s=sigma_s,
            iterations=iterations,
            tolerance=tolerance,
            product=product,
            use_edges=bool(use_edges),
            range_weight=range_weight,
            missing_range=missing_range,
            proximity=proximity,
            progress=progress,
        )
        return SynthesisResult(
            range=bp.range,
            confidence=bp.confidence,
            order=bp.order,
            edges=edge_map,
            method=method,
            params=params,
            iterations=bp.iterations,
            candidate_values=bp.candidate_values,
        )

    params.update(epsilon=epsilon, use_isophotes=bool(use_isophotes), ordering=ordering)
    filled, confidence, order = np_fill(
        image,
        range_values,
        edge_map,
        rng,
        neighbourhood=neighbourhood,
        radius=radius,
        epsilon=epsilon,
        use_edges=bool(use_edges),
        use_isophotes=bool(use_isophotes),
        ordering=ordering,
        range_weight=range_weight,
        missing_range=missing_range,
        progress=progress,
    )
    return SynthesisResult(
        range=filled,
        confidence=confidence,
        order=order,
        edges=edge_map,
        method=method,
        params=params,
    )
