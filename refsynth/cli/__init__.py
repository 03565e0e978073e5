"""The command line: ``python -m refsynth demo | synth | scan | register | evaluate | figures``.

Every argparse parser lives in this subpackage; library code never imports it.
"""

from refsynth.cli.main import main

__all__ = ["main"]
