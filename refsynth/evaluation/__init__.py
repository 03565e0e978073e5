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

from refsynth.evaluation.aggregation import (
    PAIRWISE_FINDINGS,
    TIMING_FIELDS,
    aggregate,
    findings,
    fsum_mean,
    without_timing,
)
from refsynth.evaluation.baselines import (
    BASELINES,
    colorization_affinities,
    colorization_fill,
    harmonic_fill,
    joint_bilateral_fill,
    linear_fill,
    nearest_fill,
)
from refsynth.evaluation.cases import (
    DEFAULT_GRID,
    DEFAULT_SAMPLINGS,
    DISTANCE_KNOWN_FRACTION,
    QUICK_GRID,
    SYNTHESIS_METHODS,
    Case,
    build_cases,
    grid_cases,
    known_mask,
    load_scene,
    method_names,
    parse_list,
    parse_method,
    parse_sampling,
    parse_scene,
    parse_size,
    scene_label,
    size_tuple,
)
from refsynth.evaluation.metrics import (
    BAD_THRESHOLDS,
    bad_pixel_rate,
    evaluate,
    evaluated_pixels,
    mar,
    rmse,
)
from refsynth.evaluation.reports import (
    PAPER,
    format_findings,
    format_paper_comparison,
    format_pivot,
    format_results,
    format_runtimes,
    format_winners,
)
from refsynth.evaluation.results_io import CSV_FIELDS, read_json, write_csv, write_json
from refsynth.evaluation.runner import ProgressCallback, case_cost, run_case, run_cases, score

__all__ = [
    # metrics (Eq. 13)
    "BAD_THRESHOLDS",
    "evaluated_pixels",
    "mar",
    "rmse",
    "bad_pixel_rate",
    "evaluate",
    # baselines
    "BASELINES",
    "nearest_fill",
    "linear_fill",
    "harmonic_fill",
    "colorization_affinities",
    "colorization_fill",
    "joint_bilateral_fill",
    # cases
    "Case",
    "SYNTHESIS_METHODS",
    "DEFAULT_SAMPLINGS",
    "DISTANCE_KNOWN_FRACTION",
    "DEFAULT_GRID",
    "QUICK_GRID",
    "method_names",
    "scene_label",
    "size_tuple",
    "parse_scene",
    "parse_size",
    "parse_sampling",
    "parse_method",
    "parse_list",
    "build_cases",
    "grid_cases",
    "load_scene",
    "known_mask",
    # the runner
    "ProgressCallback",
    "score",
    "run_case",
    "case_cost",
    "run_cases",
    # aggregation and findings
    "TIMING_FIELDS",
    "PAIRWISE_FINDINGS",
    "fsum_mean",
    "aggregate",
    "without_timing",
    "findings",
    # reports and files
    "PAPER",
    "format_results",
    "format_pivot",
    "format_runtimes",
    "format_findings",
    "format_winners",
    "format_paper_comparison",
    "CSV_FIELDS",
    "write_json",
    "read_json",
    "write_csv",
]
