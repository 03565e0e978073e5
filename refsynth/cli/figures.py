"""TEMPORARY shim: the `figures` subcommand moves here from refsynth.plotting."""

from refsynth.plotting.figures import add_figures_parser  # noqa: F401
