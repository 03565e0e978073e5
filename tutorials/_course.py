"""What every tutorial of the refsynth course shares: where figures go, and how they are shown.

Each tutorial imports ``from _course import save`` (and ``OUT`` if it writes
other files) before it draws anything; this file sits beside the tutorials,
and ``python -m refsynth notebooks`` copies it beside the notebooks it
writes. Then:

* run as plain Python (``python tutorials/01_np_range_synthesis.py``), the
  tutorial uses matplotlib's Agg backend and :func:`save` writes each figure
  to ``OUT`` (``tutorial-output/``, or ``$REFSYNTH_TUTORIAL_OUT``);
* run in a Jupyter kernel (Jupyter, JupyterLab, VS Code, or ``nbclient`` as
  ``python -m refsynth notebooks`` and the tests use it), :func:`save` writes
  the same file *and* shows the figure inline, as an ``image/png`` output of
  the cell. The kernel is found from ``sys.modules`` and ``get_ipython()``:
  current kernels do not announce themselves in ``MPLBACKEND``.

This module is part of the course, not of the ``refsynth`` package.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

__all__ = ["IN_KERNEL", "OUT", "in_kernel", "save"]


def in_kernel() -> bool:
    """True when this code runs in a Jupyter (IPython) kernel.

    A terminal IPython shell is not a kernel: it has no ``kernel`` attribute
    and cannot show inline images, so it counts as plain Python.
    """
    if "ipykernel" not in sys.modules:
        return False
    from IPython import get_ipython

    shell = get_ipython()
    return shell is not None and getattr(shell, "kernel", None) is not None


IN_KERNEL = in_kernel()
if IN_KERNEL:
    # Inline figures whatever MPLBACKEND says (CI sets it to Agg for the whole run).
    from IPython import get_ipython

    get_ipython().run_line_magic("matplotlib", "inline")
else:
    matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)

OUT = Path(os.environ.get("REFSYNTH_TUTORIAL_OUT", "tutorial-output"))
OUT.mkdir(parents=True, exist_ok=True)


def save(fig, name: str, dpi: int = 100) -> Path:
    """Write ``fig`` to ``OUT / name``; in a kernel, also show it inline; then close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (closed afterwards, so a cell never shows it twice).
    name : str
        File name, e.g. ``"01_scene.png"``.
    dpi : int, default 100
        Resolution of the file and of the inline image (the same pixels).

    Returns
    -------
    pathlib.Path
        Where the figure was written.
    """
    path = OUT / name
    fig.savefig(path, dpi=dpi)
    if IN_KERNEL:
        from IPython.display import Image, display

        display(Image(filename=str(path)))
    plt.close(fig)
    return path
