"""``python -m signorini``: see ``signorini.cli``."""

import sys

from .cli import main

sys.exit(main())
