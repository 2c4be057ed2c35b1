"""``python -m liebridge.cli``: the ``liebridge`` command."""

import sys

from . import main

sys.exit(main())
