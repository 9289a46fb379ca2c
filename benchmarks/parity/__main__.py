"""``python -m benchmarks.parity`` (from vigen's repository root): the parity tool's command line."""

import sys

from benchmarks.parity.cli import main

if __name__ == "__main__":
    sys.exit(main())
