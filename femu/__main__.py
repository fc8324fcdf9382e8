"""`python -m femu ...` is the `femu` command."""

import sys

from femu.cli import main

sys.exit(main())
