"""``python -m sgt_tui``: the same as the ``sgt`` command."""

import sys

from sgt_tui.cli import main

sys.exit(main())
