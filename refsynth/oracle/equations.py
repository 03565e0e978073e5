r"""Per-equation golden cases: small batches of inputs and what each equation gives.

Every kind of case names the equation, the refsynth function that computes the expected
values, the comparison it is held to (:data:`KINDS`), and its inputs and outputs:

============== ==================================================== =========== ==================
kind           expected values from                                 tolerance   outputs
============== ==================================================== =========== ==================
eq2            ``reference.eq2_distance`` (quantised windows)       exact       distance_mean, …
eq5            Eq. 5's set and the draw ``floor(u |Γ'|)``           exact       members, chosen
eq6            ``reference.overlap_mean_square``, ``−ms / 2σ_s²``   exact       mean_square,
                                                                                log_psi
eq7            ``−d / 2σ_i²``                                       exact       log_phi
eq10_12        ``reference.priority_terms``, the confidence given   exact       C, D, E_term, P, …
eq13           ``evaluation.metrics.mar``                           float64     mar
canny          ``synthesis.canny.canny``                            exact       edges
eq14           ``registration.cylinder_coordinates``                float64     x_c, y_c
eq15_17        ``registration.gauss_newton_step``                   float64     delta
eq15_17_align  ``registration.align_translation``                   float64     translation
eq18           ``registration.hat_weight``                          float64     weight
eq19           ``registration.spherical_to_cylindrical``            float64     r_c, phi_c, h
eq20           ``registration.eq20_warp``                           float64     uv
eq21           ``registration.fit_warp``                            float64     warp
============== ==================================================== =========== ==================

The inputs and outputs of each kind, B the batch:

- ``eq2``: ``q_intensity`` (B, 2, n, n, C) and ``q_range`` (B, 2, n, n) int64 (−1 unknown),
  index 0 of axis 1 the target (the pixel being filled, whose known pixels weigh the
  mean-filled range term) and index 1 the candidate; option ``range_weight``; outputs
  ``distance_mean``, ``distance_ignore`` (B,) (``missing_range`` "mean" and "ignore", the
  channel sum) and ``distance_mean_channel_mean``, ``distance_ignore_channel_mean`` (B,) (the
  channel mean); ``window`` (n, n) int64 prepared.
- ``eq5``: ``distances`` (B, M) with ties, ``draws`` (B,); ``epsilon`` → ``members`` (B, M)
  bool, ``chosen`` (B,) int64 (an index into the row).
- ``eq6``: ``first``, ``second`` (B, n, n) quantised range patches; ``direction`` ("h": the
  second is right of the first, "v": below), ``sigma_s`` → ``mean_square``, ``log_psi`` (B,).
- ``eq7``: ``distances`` (B, k); ``sigma_i`` → ``log_phi`` (B, k).
- ``eq10_12``: hand-built 9×9 windows ``filled``, ``q_range``, ``confidence``, ``edges``
  (B, 9, 9), the target ``pixel`` and the ``best`` match (B, 2) (row, column);
  ``neighbourhood``, ``use_isophotes`` → ``C``, ``D``, ``E_term``, ``P``, ``edge_count``,
  ``assigned_product``, ``assigned_best`` (B,). ``eq10_12-arithmetic``'s windows are the
  ones where Eq. 12's other operation orders give another ``D`` (an ulp): only the
  contract's ``1 − |g_row m_col − g_col m_row| / ‖m‖``, the un-normalised Sobel vector
  divided by its norm once, passes it (:mod:`refsynth.oracle.contract`).
- ``eq13``: ``estimate``, ``truth``, ``known`` (H, W) → ``mar`` ().
- ``canny``: ``image`` (H, W); ``sigma`` → ``edges`` (H, W) bool.
- the registration stage: Eq. 14 ``x``, ``y``; ``focal`` → ``x_c``, ``y_c``; Eqs. 15–17
  ``reference``, ``moving`` (B, 24, 24), ``translation`` (B, 2) → ``delta`` (B, 2), and
  ``reference``, ``moving``, ``initial`` (2,); ``levels``, ``search``, ``photometric`` →
  ``translation`` (2,); Eq. 18 ``x``, ``y``; ``width``, ``height`` → ``weight``; Eq. 19
  ``r``, ``theta``, ``phi``; ``focal`` → ``r_c``, ``phi_c``, ``h``; Eq. 20 ``laser_points``
  (N, 2), ``r`` (N,); ``a``, ``b``, ``alpha``, ``v0``, ``focal``, ``delta_y`` → ``uv`` (N, 2);
  Eq. 21 ``laser_points``, ``camera_points`` (N, 2) → ``warp`` (4,) (a, b, α, β).

"exact" kinds are under the numeric contract (their inputs are integers or exact binary
fractions, and every operation is fixed), so the same bits hold on every machine. The
registration stage and Eq. 13 are not: they use BLAS products, ``arctan2`` and ``np.mean``,
so their golden values hold to the float64 tolerance (:data:`refsynth.oracle.check.TOLERANCES`).
"""

from __future__ import annotations

import numpy as np

from refsynth.numeric import NO_RANGE, on_confidence_grid, window_weights
from refsynth.synthesis import reference as ref

__all__ = ["KINDS", "equation_cases", "equation_outputs"]

#: kind → (the equation, the function behind the expected values, the case's own tolerance).
KINDS = {
    "np": ("Eqs. 2-5, 10-12: a whole NP run", "synthesis.reference.np_reference", "exact"),
    "bp": ("Eqs. 2, 6-9: a whole BP run", "synthesis.reference.bp_reference", "exact"),
    "eq2": ("Eq. 2: the neighbourhood distance", "synthesis.reference.eq2_distance", "exact"),
    "eq5": ("Eq. 5: the near-best set and its draw", "synthesis.reference (np_reference)",
            "exact"),
    "eq6": ("Eq. 6: the pairwise compatibility", "synthesis.reference.overlap_mean_square",
            "exact"),
    "eq7": ("Eq. 7: the local evidence", "synthesis.reference (bp_reference)", "exact"),
    "eq10_12": ("Eqs. 10-12: the priority terms, Eq. 11's confidence given",
                "synthesis.reference.priority_terms", "exact"),
    "eq13": ("Eq. 13: the mean absolute residual", "evaluation.metrics.mar", "float64"),
    "canny": ("Canny's edges (§3.2.4)", "synthesis.canny.canny", "exact"),
    "eq14": ("Eq. 14: perspective to cylinder", "registration.cylinder_coordinates", "float64"),
    "eq15_17": ("Eqs. 15-17: one Gauss-Newton step", "registration.gauss_newton_step",
                "float64"),
    "eq15_17_align": ("Eqs. 15-17: the translation, coarse to fine",
                      "registration.align_translation", "float64"),
    "eq18": ("Eq. 18: the hat weight", "registration.hat_weight", "float64"),
    "eq19": ("Eq. 19: spherical to cylindrical", "registration.spherical_to_cylindrical",
             "float64"),
    "eq20": ("Eq. 20: the exact warp", "registration.eq20_warp", "float64"),
    "eq21": ("Eq. 21: the global warp's least squares", "registration.fit_warp", "float64"),
}


# ----------------------------------------------------------------------------- builders


def _eq2_cases(g) -> list:
    cases = []
    for n, channels in ((3, 1), (5, 3)):
        qi = g.integers(0, 2**16 + 1, (32, 2, n, n, channels))
        qi[:4, 1] = qi[:4, 0]      # identical intensity: only the range term is left
        qr = np.where(g.random((32, 2, n, n)) < 0.6, g.integers(0, 2**16 + 1, (32, 2, n, n)),
                      NO_RANGE)
        qr[4:6] = NO_RANGE         # no range at all: the mean-filled term's prior alone
        cases.append((f"eq2-n{n}-c{channels}", "eq2", dict(q_intensity=qi, q_range=qr),
                      dict(range_weight=16.0)))
    return cases


def _eq5_cases(g) -> list:
    distances = np.round(g.random((16, 20)), 2)   # ties on purpose
    distances[0] = 0.25                           # all equal: every candidate is in Γ'
    distances[1, 3] = 0.0                         # a perfect match: Γ' holds the zeros only
    draws = g.random(16)
    draws[2] = 0.0
    return [("eq5-ties", "eq5", dict(distances=distances, draws=draws), dict(epsilon=0.1)),
            ("eq5-eps0", "eq5", dict(distances=distances, draws=draws), dict(epsilon=0.0))]


def _eq6_cases(g) -> list:
    cases = []
    for direction in ("h", "v"):
        first = np.where(g.random((24, 5, 5)) < 0.7, g.integers(0, 2**16 + 1, (24, 5, 5)),
                         NO_RANGE)
        second = np.where(g.random((24, 5, 5)) < 0.7, g.integers(0, 2**16 + 1, (24, 5, 5)),
                          NO_RANGE)
        second[:3] = NO_RANGE                     # nothing shared: Ψ = 1
        cases.append((f"eq6-{direction}", "eq6", dict(first=first, second=second),
                      dict(direction=direction, sigma_s=0.2)))
    return cases


def _eq7_cases(g) -> list:
    distances = np.round(g.random((8, 6)) * 0.05, 6)
    return [("eq7", "eq7", dict(distances=distances), dict(sigma_i=0.1))]


def _window(kind: str, g, m: int = 9):
    """A hand-built 9×9 image around a front pixel (row 4, col 4 unless at the border)."""
    filled = np.zeros((m, m), bool)
    q = np.zeros((m, m), np.int64)
    rows, cols = np.indices((m, m))
    pixel = (4, 4)
    if kind == "flat":                  # no range gradient: D = 1
        filled[:, :4] = True
        q[:] = 30000
    elif kind == "ramp-along-front":    # the isophote crosses the front: D small
        filled[:, :4] = True
        q = 4000 * rows
    elif kind == "ramp-into-hole":      # the gradient along the normal: D = 1
        filled[:, :4] = True
        q = 4000 * cols
    elif kind == "diagonal":
        filled = rows + cols < 8
        q = 2000 * rows + 1000 * cols
    elif kind == "corner":              # the pixel at the image's corner: |N_p| = 9
        filled[1:, 1:] = True
        filled[1, 1] = False
        q = 3000 * rows
        pixel = (0, 0)
    else:                               # random
        filled = g.random((m, m)) < 0.55
        filled[4, 4] = False
        filled[3, 3] = True
        q = g.integers(0, 2**16 + 1, (m, m))
    conf = np.where(filled, np.round(g.random((m, m)) * 2**12) * 2.0**-12, 0.0)
    conf[filled & (g.random((m, m)) < 0.4)] = 1.0
    edges = g.random((m, m)) < (0.2 if kind != "flat" else 0.0)
    best = np.argwhere(filled)[g.integers(int(filled.sum()))]
    return filled, np.where(filled, q, NO_RANGE), conf, edges, np.array(pixel), best


def _priority_cases(g) -> list:
    kinds = ["flat", "ramp-along-front", "ramp-into-hole", "diagonal", "corner"] + ["random"] * 11
    windows = [_window(kind, g) for kind in kinds]
    inputs = {key: np.stack([w[i] for w in windows]) for i, key in enumerate(
        ("filled", "q_range", "confidence", "edges", "pixel", "best"))}
    return [("eq10_12-n5", "eq10_12", inputs, dict(neighbourhood=5, use_isophotes=True)),
            ("eq10_12-n3-no-isophotes", "eq10_12", inputs,
             dict(neighbourhood=3, use_isophotes=False)),
            ("eq10_12-arithmetic", "eq10_12", _arithmetic_windows(),
             dict(neighbourhood=5, use_isophotes=True))]


#: Seeds of random windows on which Eq. 12's other operation orders (the Sobel vector
#: normalised before the cross product; each product divided by ``‖m‖`` separately; a
#: multiplication by ``1 / ‖m‖``) each give a ``D`` one ulp or more away from the
#: contract's ``1 − |g_row m_col − g_col m_row| / ‖m‖`` (found by a search over seeds).
ARITHMETIC_SEEDS = (54, 87, 303, 387)


def _arithmetic_windows() -> dict:
    """The ``eq10_12-arithmetic`` batch: windows where only the contract's order of Eq. 12 passes.

    Each window is drawn from its own seed (:data:`ARITHMETIC_SEEDS`), so the other
    cases' draws are untouched.
    """
    windows = [_window("random", np.random.default_rng(seed)) for seed in ARITHMETIC_SEEDS]
    return {key: np.stack([w[i] for w in windows]) for i, key in enumerate(
        ("filled", "q_range", "confidence", "edges", "pixel", "best"))}


def _mar_cases(g) -> list:
    truth = np.round(1 + 4 * g.random((16, 16)), 3)
    truth[0, :3] = np.nan                         # no ground truth there
    known = g.random((16, 16)) < 0.4
    estimate = np.where(known, truth, np.round(truth + g.normal(0, 0.3, (16, 16)), 3))
    return [("eq13", "eq13", dict(estimate=np.nan_to_num(estimate, nan=2.0), truth=truth,
                                  known=known), {})]


def _canny_cases(g) -> list:
    rows, cols = np.indices((32, 32))
    disc = ((rows - 15.5) ** 2 + (cols - 13.0) ** 2 < 90).astype(np.float64)
    step = np.where(cols[:16, :16] < 7, 0.2, 0.8) + 0.02 * g.standard_normal((16, 16))
    ramp = np.clip(cols[:20, :24] / 23 + 0.05 * g.standard_normal((20, 24)), 0, 1)
    levels = g.integers(0, 4, (24, 24)) / 3.0
    return [("canny-disc", "canny", dict(image=0.1 + 0.7 * disc), dict(sigma=0.8)),
            ("canny-step-noise", "canny", dict(image=step), dict(sigma=0.8)),
            ("canny-ramp", "canny", dict(image=ramp), dict(sigma=1.5)),
            ("canny-levels", "canny", dict(image=levels), dict(sigma=0.8))]


def _registration_cases(g) -> list:
    cases = [("eq14", "eq14", dict(x=g.uniform(-200, 200, 24), y=g.uniform(-150, 150, 24)),
              dict(focal=300.0))]
    yy, xx = np.mgrid[0:24, 0:24] / 4.0

    def texture(dx, dy):
        x, y = xx + dx, yy + dy
        return np.sin(x) + np.cos(0.7 * y) + 0.3 * np.sin(0.5 * x + y)

    shifts = np.array([[0.3, -0.2], [-0.5, 0.4], [1.0, 0.0], [0.0, 0.7]])
    cases.append(("eq15_17", "eq15_17", dict(
        reference=np.stack([texture(0, 0)] * 4),
        moving=np.stack([texture(sx / 4, -sy / 4) for sx, sy in shifts]),
        translation=np.array([[0.0, 0.0], [0.2, 0.1], [0.5, 0.0], [0.0, 0.0]])), {}))
    yy, xx = np.mgrid[0:40, 0:64] / 5.0
    scene = np.sin(xx) * np.cos(0.8 * yy) + 0.3 * np.sin(0.5 * xx + yy)
    cases.append(("eq15_17-align", "eq15_17_align", dict(
        reference=scene[:, :40], moving=scene[3:, 26:], initial=np.array([24.0, 0.0])),
        dict(levels=2, search=[2, 2], photometric=False)))
    cases.append(("eq18", "eq18", dict(x=g.uniform(-1, 41, 24), y=g.uniform(-1, 31, 24)),
                  dict(width=40.0, height=30.0)))
    cases.append(("eq19", "eq19", dict(r=g.uniform(1, 8, 24), theta=g.uniform(0.3, 2.8, 24),
                                       phi=g.uniform(-3, 3, 24)), dict(focal=300.0)))
    laser = np.column_stack([g.uniform(-1, 1, 12), g.uniform(-80, 80, 12)])
    cases.append(("eq20", "eq20", dict(laser_points=laser, r=g.uniform(2, 8, 12)),
                  dict(a=300.0, b=-1.0, alpha=12.0, v0=120.0, focal=300.0, delta_y=0.05)))
    camera = np.column_stack([300 * laser[:, 0] + 12 + g.normal(0, 0.5, 12),
                              -laser[:, 1] + 90 + g.normal(0, 0.5, 12)])
    cases.append(("eq21", "eq21", dict(laser_points=laser, camera_points=camera), {}))
    return cases


def equation_cases() -> list[tuple]:
    """``(name, kind, inputs, options)`` of every per-equation case, from fixed seeds."""
    g = np.random.default_rng(7)
    return (_eq2_cases(g) + _eq5_cases(g) + _eq6_cases(g) + _eq7_cases(g)
            + _priority_cases(g) + _mar_cases(g) + _canny_cases(g) + _registration_cases(g))


# ----------------------------------------------------------------------------- expected


def _eq2(inputs, options):
    qi, qr = inputs["q_intensity"], inputs["q_range"]
    window = window_weights(qi.shape[2])
    out = dict(window=window)
    for rule in ("mean", "ignore"):
        for channels, suffix in (("sum", ""), ("mean", "_channel_mean")):
            out[f"distance_{rule}{suffix}"] = np.array([
                ref.eq2_distance(qi[b, 0], qr[b, 0], qi[b, 1], qr[b, 1], window,
                                 options["range_weight"], rule, channels)
                for b in range(len(qi))])
    return out


def _eq5(inputs, options):
    d, u, eps = inputs["distances"], inputs["draws"], options["epsilon"]
    members = np.zeros(d.shape, bool)
    chosen = np.zeros(len(d), np.int64)
    for b, row in enumerate(d):
        distances = [float(x) for x in row]
        best = distances.index(min(distances))                  # Eq. 4, the first minimum
        threshold = (1.0 + eps) * distances[best]
        gamma = [i for i, x in enumerate(distances) if x <= threshold]
        members[b, gamma] = True
        chosen[b] = gamma[int(u[b] * len(gamma))]
    return dict(members=members, chosen=chosen)


def _eq6(inputs, options):
    sigma = options["sigma_s"]
    ms = np.array([ref.overlap_mean_square(a, b, options["direction"])
                   for a, b in zip(inputs["first"], inputs["second"])])
    return dict(mean_square=ms, log_psi=-ms / (2.0 * sigma * sigma))


def _eq10_12(inputs, options):
    n, iso = options["neighbourhood"], options["use_isophotes"]
    out = {key: [] for key in ("C", "D", "E_term", "P", "edge_count", "assigned_product",
                               "assigned_best")}
    for filled, qr, conf, edges, (r, c), (br, bc) in zip(*(inputs[k] for k in (
            "filled", "q_range", "confidence", "edges", "pixel", "best"))):
        h = n // 2
        count = int(edges[max(r - h, 0) : r + h + 1, max(c - h, 0) : c + h + 1].sum())
        C, D, E = ref.priority_terms(int(r), int(c), filled, qr, conf, count, n,
                                     use_isophotes=iso)
        c_best = ref.confidence_term(conf, int(br), int(bc), n)
        for key, value in zip(out, (C, D, E, C * max(D, 0.0) + E, count,
                                    on_confidence_grid(C * c_best), on_confidence_grid(c_best))):
            out[key].append(value)
    return {key: np.array(value, np.int64 if key == "edge_count" else np.float64)
            for key, value in out.items()}


def _registration(kind, inputs, options):
    from refsynth import registration as reg

    if kind == "eq14":
        x_c, y_c = reg.cylinder_coordinates(inputs["x"], inputs["y"], options["focal"])
        return dict(x_c=x_c, y_c=y_c)
    if kind == "eq15_17":
        return dict(delta=np.array([reg.gauss_newton_step(a, b, t) for a, b, t in zip(
            inputs["reference"], inputs["moving"], inputs["translation"])]))
    if kind == "eq15_17_align":
        settings = dict(options, search=tuple(options["search"]))
        return dict(translation=reg.align_translation(inputs["reference"], inputs["moving"],
                                                      inputs["initial"], **settings))
    if kind == "eq18":
        return dict(weight=reg.hat_weight(inputs["x"], inputs["y"], options["width"],
                                          options["height"]))
    if kind == "eq19":
        r, phi, h = reg.spherical_to_cylindrical(inputs["r"], inputs["theta"], inputs["phi"],
                                                 options["focal"])
        return dict(r_c=r, phi_c=phi, h=h)
    if kind == "eq20":
        return dict(uv=reg.eq20_warp(inputs["laser_points"], inputs["r"], **options))
    return dict(warp=np.array(reg.fit_warp(inputs["laser_points"], inputs["camera_points"]),
                              np.float64))


def equation_outputs(kind: str, inputs: dict, options: dict) -> dict:
    """The expected outputs of a per-equation case (see the module's table)."""
    if kind == "eq2":
        return _eq2(inputs, options)
    if kind == "eq5":
        return _eq5(inputs, options)
    if kind == "eq6":
        return _eq6(inputs, options)
    if kind == "eq7":
        sigma = options["sigma_i"]
        return dict(log_phi=np.array([[-d / (2.0 * sigma * sigma) for d in row]
                                      for row in inputs["distances"]]))
    if kind == "eq10_12":
        return _eq10_12(inputs, options)
    if kind == "eq13":
        from refsynth.evaluation.metrics import mar

        return dict(mar=np.array(mar(inputs["estimate"], inputs["truth"], inputs["known"])))
    if kind == "canny":
        from refsynth.synthesis.canny import canny

        return dict(edges=canny(inputs["image"], **options))
    return _registration(kind, inputs, options)
