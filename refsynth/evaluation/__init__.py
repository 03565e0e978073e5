"""Evaluation (§3.3, Eq. 13): the measures, the baselines, the experiment runner, the reports.

- :mod:`refsynth.evaluation.metrics`: the mean absolute residual of Eq. 13
  over the pixels that were unknown and have ground truth, beside RMSE and
  the Middlebury bad-pixel rates.
- :mod:`refsynth.evaluation.baselines`: the fills people use today (nearest,
  linear, harmonic, colorization, joint-bilateral), set beside NP and BP.
- :mod:`refsynth.evaluation.cases`: the experiments' cases (scene × size ×
  sampling × method × seed) as compact specs, and what they denote.
- :mod:`refsynth.evaluation.runner`: fill and score each case, in this
  process, in local processes or on a Dask cluster.
- :mod:`refsynth.evaluation.aggregation`: the mean and spread over seeds, and
  the paper's relative findings checked on them.
- :mod:`refsynth.evaluation.reports`: Markdown tables, and the paper's
  numbers beside ours; :mod:`refsynth.evaluation.results_io`: JSON and CSV.

The command line (``python -m refsynth evaluate``) is :mod:`refsynth.cli.evaluate`.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3 and Eq. 13, doi:10.1007/s11263-007-0108-2.
"""

from refsynth.evaluation import (
    aggregation,
    baselines,
    cases,
    metrics,
    reports,
    results_io,
    runner,
)
from refsynth.evaluation.aggregation import *  # noqa: F403
from refsynth.evaluation.baselines import *  # noqa: F403
from refsynth.evaluation.cases import *  # noqa: F403
from refsynth.evaluation.metrics import *  # noqa: F403
from refsynth.evaluation.reports import *  # noqa: F403
from refsynth.evaluation.results_io import *  # noqa: F403
from refsynth.evaluation.runner import *  # noqa: F403

#: Every module's public names (its own ``__all__``, the one list of them), in the order of
#: the list above: metrics (Eq. 13), baselines, cases, the runner, aggregation and findings,
#: reports and files.
__all__ = [
    *metrics.__all__,
    *baselines.__all__,
    *cases.__all__,
    *runner.__all__,
    *aggregation.__all__,
    *reports.__all__,
    *results_io.__all__,
]
