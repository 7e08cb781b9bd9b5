"""``python -m spine_gym.experiments``: :func:`.reproduction.main`."""

import sys

from .reproduction import main

if __name__ == "__main__":
    sys.exit(main())
