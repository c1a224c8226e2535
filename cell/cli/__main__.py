"""``python -m cell.cli``: the ``musclecell`` command without its console script."""

import sys

from cell.cli import main

sys.exit(main())
