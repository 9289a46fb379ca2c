"""``vigen.data`` is now :mod:`vigen.datasets`: ``python -m vigen.data ...`` exits with status 2 naming the new command.

Nothing else is left under the old name (it read like ``torchrl.data``, TorchRL's replay buffers).

Examples:
    >>> import subprocess, sys
    >>> result = subprocess.run([sys.executable, "-m", "vigen.data", "list"], capture_output=True, text=True)
    >>> result.returncode, result.stderr.strip()
    (2, 'error: vigen.data is now vigen.datasets: run `python -m vigen.datasets list`.')
"""

import shlex
import sys

if __name__ == "__main__":
    print(f"error: vigen.data is now vigen.datasets: run `{shlex.join(['python', '-m', 'vigen.datasets', *sys.argv[1:]])}`.",
          file=sys.stderr)
    sys.exit(2)
