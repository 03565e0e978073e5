"""The command line: every `python -m refsynth` subcommand, one module each.

Every argparse parser lives in this subpackage, one module per subcommand;
:mod:`refsynth.cli.main` gathers them. Library code never imports it.
"""
