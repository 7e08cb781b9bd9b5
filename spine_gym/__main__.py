"""``python -m spine_gym``: the ``spine-gym`` command line (:mod:`spine_gym.cli`)."""

import sys

from spine_gym.cli import main

if __name__ == "__main__":
    sys.exit(main())
