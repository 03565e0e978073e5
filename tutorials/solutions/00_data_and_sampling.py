"""Solutions to the exercises of tutorial 0 (the data: scenes, partial range, Eq. 13).

Run as ``python tutorials/solutions/00_data_and_sampling.py``; the test suite
runs it too. Each exercise prints its numbers and asserts the claims its
answer makes, so a change in refsynth that breaks an answer fails a test.
"""

import numpy as np
from scipy import ndimage

from refsynth.acquisition import distance_driven, stripes, unknown_fraction
from refsynth.evaluation import mar, nearest_fill
from refsynth.scenes import motorcycle, synthetic_room


def exercise_1() -> None:
    """Eq. 13 over the wrong pixels.

    Averaging over every pixel with ground truth adds the measured pixels,
    whose residual is exactly 0 (the fill copies them): the sum of residuals
    is unchanged, the count grows from the unknown pixels to all of them, so
    the score is MAR × (unknown fraction) — 35 % lower at 64.8 % unknown,
    and lower the more is measured. Two papers that average over different
    pixels cannot be compared, and a sparse sampling would look worse than it
    is against a dense one; hence Eq. 13's denominator.
    """
    room = synthetic_room((128, 128), seed=0)
    known = stripes(room.shape, 5, 25, axes="xy")
    fill = nearest_fill(room.intensity, np.where(known, room.range, np.nan))
    over_all = np.abs(fill - room.range)[room.has_truth].mean()
    eq13 = mar(fill, room.range, known)
    fraction = unknown_fraction(known)
    print(f"1. over all pixels {over_all:.4f} m; MAR {eq13:.4f} m x unknown fraction "
          f"{fraction:.3f} = {eq13 * fraction:.4f} m")
    assert np.isclose(over_all, eq13 * fraction, rtol=1e-12)
    assert over_all < eq13


def exercise_2() -> None:
    """Layout against fraction.

    The three grids leave nearly the same fraction unknown, but the nearest
    fill's error grows with the width of the holes: an unknown pixel in a
    65-pixel hole is on average much further from any measurement than one in
    a 25-pixel hole, and the range has more room to change in between.
    """
    room = synthetic_room((128, 128), seed=0)
    results = []
    for rw, xw in [(5, 25), (8, 40), (12, 60)]:
        known = stripes(room.shape, rw, xw, axes="xy")
        fill = nearest_fill(room.intensity, np.where(known, room.range, np.nan))
        results.append((xw, unknown_fraction(known), mar(fill, room.range, known)))
        print(f"2. grid {rw}/{xw}: {100 * results[-1][1]:.1f} % unknown, "
              f"nearest MAR {results[-1][2]:.3f} m")
    fractions = [fraction for _, fraction, _ in results]
    errors = [error for _, _, error in results]
    assert max(fractions) - min(fractions) < 0.02  # "about the same fraction"
    assert errors == sorted(errors)  # the error follows the hole width
    assert errors[-1] > 1.5 * errors[0]


def exercise_3() -> None:
    """Fig. 2 on a real scene.

    With the same number of slices (whole columns), the evenly spaced ones
    give the nearest fill the *lower* MAR on the Motorcycle: the
    distance-driven columns are dense over the far background and sparse
    over the near motorcycle, so their gaps are uneven, and an unknown pixel
    is on average further from a measured one (the mean distance printed).
    Every column also holds far background above and below the bike, so
    the sparse columns lose there too. Fig. 2's argument is about a robot
    giving far surfaces, which look small, enough samples to learn from — not
    about the error of the nearest fill; whether NP profits from it is a
    question for tutorial 1's tools.
    """
    bike = motorcycle(128)
    truth = bike.has_truth
    driven = distance_driven(1.0 / bike.range, 0.4)  # 1 / disparity: larger is farther
    slices = int(driven.any(axis=0).sum())
    even = np.zeros(bike.shape, dtype=bool)
    even[:, np.round(np.linspace(0, bike.shape[1] - 1, slices)).astype(int)] = True
    scores = {}
    for name, known in {"evenly spaced": even & truth, "distance-driven": driven & truth}.items():
        fill = nearest_fill(bike.intensity, np.where(known, bike.range, np.nan))
        distance = ndimage.distance_transform_edt(~known)[~known & truth].mean()
        scores[name] = (mar(fill, bike.range, known), distance)
        print(f"3. {slices} slices, {name}: {100 * unknown_fraction(known):.1f} % unknown, "
              f"mean distance {distance:.2f} px, nearest MAR {scores[name][0]:.3f} px")
    assert scores["distance-driven"][0] > scores["evenly spaced"][0]
    assert scores["distance-driven"][1] > scores["evenly spaced"][1]


if __name__ == "__main__":
    exercise_1()
    exercise_2()
    exercise_3()
