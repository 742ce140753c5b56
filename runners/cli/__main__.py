"""``python -m runners.cli``: the same as the ``runners`` console script."""

import sys

from runners.cli.console import main

sys.exit(main())
