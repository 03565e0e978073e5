"""The comparison fills."""

import numpy as np
import pytest
from hypothesis import given
from strategies import small_scene

from refsynth.baselines import nearest_fill


@given(small_scene())
def test_nearest_fill_copies_from_a_nearest_known_pixel(scene):
    image, truth, known = scene
    out = nearest_fill(image, np.where(known, truth, np.nan))
    np.testing.assert_array_equal(out[known], truth[known])
    rows, cols = np.nonzero(known)
    for r, c in np.argwhere(~known)[:10]:
        d = np.hypot(rows - r, cols - c)
        nearest = truth[rows[d == d.min()], cols[d == d.min()]]
        assert out[r, c] in nearest


def test_nearest_fill_validates_like_synthesize():
    with pytest.raises(ValueError, match="no known range"):
        nearest_fill(np.zeros((4, 4)), np.full((4, 4), np.nan))
