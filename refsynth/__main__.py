"""``python -m refsynth``: see :mod:`refsynth.cli.main`."""

import sys

from refsynth.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
