"""Solutions to the exercises of tutorial 3 (registration, Appendix A).

Run as ``python tutorials/solutions/03_registration.py``; the test suite runs
it too. Each exercise prints its numbers and asserts the claims its answer
makes, so a change in refsynth that breaks an answer fails a test.
"""

import numpy as np
from scipy import ndimage

from refsynth.registration import fit_warp, gauss_newton_step
from refsynth.scenes import DELTA_Y, FOCAL, laser_scan, rig_room


def eq17_step(reference: np.ndarray, moving: np.ndarray, t: np.ndarray) -> np.ndarray:
    """One Gauss–Newton step of Eqs. 15–17, written out with numpy.

    ``e_i = I1(x_i + t) − I0(x_i)`` and ``g_i = ∇I1(x_i + t)`` (central
    differences, sampled bilinearly) over the pixels where both exist, then
    ``(Σ g gᵀ) δt = −Σ e g``.
    """
    rows, cols = np.indices(moving.shape, dtype=np.float64)
    where = [rows + t[1], cols + t[0]]
    sample = lambda image: ndimage.map_coordinates(image, where, order=1, cval=np.nan)  # noqa: E731
    grad_y, grad_x = np.gradient(reference)
    e = sample(reference) - moving
    g = np.stack([sample(grad_x), sample(grad_y)], axis=-1)
    inside = (where[0] >= 0) & (where[0] <= reference.shape[0] - 1) \
        & (where[1] >= 0) & (where[1] <= reference.shape[1] - 1)
    e, g = e[inside], g[inside]
    return np.linalg.solve(g.T @ g, -(g.T @ e))


def exercise_1() -> None:
    """Implement Eq. 17 yourself and compare with refsynth's ``gauss_newton_step``.

    On two views of a smooth pattern with a known sub-pixel shift, the
    hand-written step and refsynth's agree to a few thousandths of a pixel
    (they differ only in how the image border is treated), and iterating
    either converges to the true shift in a few steps: Gauss–Newton
    converges fast when the start is within a pixel or two and the overlap
    has texture in both directions.
    """
    y, x = np.mgrid[0:60, 0:80] / 6.0
    truth = np.array([0.4, -0.25])
    reference = np.sin(x) + np.cos(0.7 * y)
    moving = np.sin(x + truth[0] / 6.0) + np.cos(0.7 * (y + truth[1] / 6.0))
    mine, theirs = np.zeros(2), np.zeros(2)
    first = None
    for _ in range(5):
        step = eq17_step(reference, moving, mine)
        ref_step = gauss_newton_step(reference, moving, theirs)
        if first is None:
            first = np.abs(step - ref_step).max()
        mine, theirs = mine + step, theirs + ref_step
    print(f"1. first steps differ by {first:.1e} px; after 5 steps: mine {np.round(mine, 4)}, "
          f"refsynth's {np.round(theirs, 4)}, truth {truth}")
    assert first < 5e-3
    assert np.abs(mine - truth).max() < 1e-3 and np.abs(theirs - truth).max() < 1e-3


def exercise_2() -> None:
    """Eq. 21 from noisy correspondences.

    Eq. 21 is two straight-line fits, so from a handful of correspondences
    on, the error of α and β falls like one over the square root of their
    number: 4 times as many points, about half the error. Two points (the
    minimum) are at the mercy of where they fall: when their φ (or h) are
    close, the slope is ill-determined, and the intercept α (β), which is the
    line's value at φ = 0 (h = 0), swings by many pixels.
    """
    rng = np.random.default_rng(0)
    a, b, alpha, beta = FOCAL, -1.0, 480.0, 110.0
    spreads = {}
    for n in (2, 8, 32, 128):
        errors = []
        for _ in range(300):
            phi = rng.uniform(-1.5, 1.5, n)
            h = rng.uniform(-90.0, 90.0, n)
            u = a * phi + alpha + rng.normal(0.0, 1.0, n)  # 1 px of noise
            v = b * h + beta + rng.normal(0.0, 1.0, n)
            fit = fit_warp(np.column_stack([phi, h]), np.column_stack([u, v]))
            errors.append(max(abs(fit.alpha - alpha), abs(fit.beta - beta)))
        spreads[n] = np.percentile(errors, 95)
        print(f"2. {n:3d} correspondences, 1 px noise: 95 % of |α, β| errors below "
              f"{spreads[n]:.2f} px")
    assert spreads[2] > 5 * spreads[8]  # two points: at the mercy of where they fall
    for n in (8, 32):
        assert 1.6 < spreads[n] / spreads[4 * n] < 2.5  # ~ 1 / sqrt(n)


def exercise_3() -> None:
    """How wrong is one β?

    Eq. 20's offset between the laser and the camera shows up in the mosaic
    as ``f ΔY / r``: with f = 300 px and ΔY = 5 cm, 10 px for furniture at
    1.5 m but under 2 px for a wall at 8 m. Eq. 21 replaces it by one
    constant β, so wherever the scene's depth differs from the depth β was
    fitted at, the range lands a few pixels off — the local stretch exists
    to fix that at the depth edges, where it can be seen.
    """
    scan = laser_scan(rig_room(2), phi_range=(-1.15, 1.15), seed=2)
    r = scan.r[np.isfinite(scan.r)]
    parallax = FOCAL * DELTA_Y / r
    low, high = np.percentile(parallax, [5, 95])
    print(f"3. f ΔY / r on the rig: {FOCAL * DELTA_Y / 1.5:.1f} px at 1.5 m, "
          f"{FOCAL * DELTA_Y / 8.0:.1f} px at 8 m; over the scan's samples "
          f"{low:.1f}–{high:.1f} px (5th–95th percentile)")
    assert FOCAL * DELTA_Y / 1.5 > 5 * FOCAL * DELTA_Y / 8.0
    assert high - low > 1.0  # no single β is right for the whole scan


if __name__ == "__main__":
    exercise_1()
    exercise_2()
    exercise_3()
