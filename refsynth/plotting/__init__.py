"""Figures (§3.3): the paper's layouts (Figs. 7, 11–17), the ``figures`` builders, the demos.

- :mod:`refsynth.plotting.layouts`: a result in the paper's layout (Figs.
  11–17: intensity, edges, partial range, result, truth, residual), methods
  side by side, every sampling × method.
- :mod:`refsynth.plotting.figures`: the analogues of Figs. 7, 11, 13, 16 and 17
  on refsynth's scenes, MAR against the unknown fraction and BP's confidence;
  :func:`make_figures` writes every PNG of ``figures/``.
- :mod:`refsynth.plotting.demo`: the demos (the synthetic room; the simulated
  pipeline), which run the methods, return the table's rows and write figures.
- :mod:`refsynth.plotting.active_story`: active scanning on the simulated rig
  beside the fixed strategies (§5, ``demo --active``).
- :mod:`refsynth.plotting.examples`: the tiny range ramp the layouts' Examples draw.

Every figure is a :class:`matplotlib.figure.Figure` built without pyplot's
global state. The command lines (``demo``, ``figures``) are in :mod:`refsynth.cli`.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.2.4 (Fig. 7), §3.3 (Figs. 11–17),
doi:10.1007/s11263-007-0108-2.
"""

from refsynth.plotting import figures
from refsynth.plotting.active_story import run_active_demo
from refsynth.plotting.demo import (
    DEMO_FIGURES,
    DEMO_METHODS,
    ProgressFactory,
    run_demo,
    run_pipeline_demo,
)
from refsynth.plotting.examples import example_ramp
from refsynth.plotting.figures import *  # noqa: F403 (the names of figures.__all__)
from refsynth.plotting.layouts import (
    comparison_figure,
    finish_figure,
    methods_figure,
    panel,
    range_scale,
    result_figure,
    save_figure,
)

__all__ = [
    # layouts
    "range_scale",
    "panel",
    "finish_figure",
    "save_figure",
    "result_figure",
    "comparison_figure",
    "methods_figure",
    # the figures builders: all of refsynth.plotting.figures
    *figures.__all__,
    # the demos
    "DEMO_METHODS",
    "DEMO_FIGURES",
    "ProgressFactory",
    "run_demo",
    "run_pipeline_demo",
    "run_active_demo",
    # the Examples' case
    "example_ramp",
]
