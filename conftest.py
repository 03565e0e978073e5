"""pytest configuration for the doctests in refsynth/ (this file is not part of the package).

The Motorcycle's example in :mod:`refsynth.scenes` needs scikit-image (the ``data`` extra).
"""

import pytest


@pytest.fixture(autouse=True)
def _needs_scikit_image(request):
    """Skip :func:`~refsynth.scenes.middlebury.motorcycle`'s example without scikit-image."""
    if request.node.name.endswith(".motorcycle"):
        try:
            from skimage import data  # noqa: F401
        except ImportError:
            pytest.skip("the Motorcycle needs scikit-image (the data extra)")
