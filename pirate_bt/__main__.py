"""``python -m pirate_bt`` is the ``pirate-bt`` command."""

import sys

from pirate_bt.cli import main

sys.exit(main())
