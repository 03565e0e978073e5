"""TEMPORARY shim: the `evaluate` subcommand moves here from refsynth.evaluation."""

from refsynth.evaluation.experiments import add_evaluate_parser  # noqa: F401
