"""`python -m femu ...` is the `femu` command."""

import sys

from femu.cli import main

if __name__ == "__main__":  # not when a worker process (forkserver, spawn) imports this module again
    sys.exit(main())
