"""``python -m refsynth``: see :mod:`refsynth.cli`."""

import sys

from refsynth.cli import main

if __name__ == "__main__":
    sys.exit(main())
