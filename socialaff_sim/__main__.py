"""``python -m socialaff_sim``: the ``socialaff-sim`` command without its console script (same sub-commands and
exit statuses), for environments where the script's directory is not on ``PATH``."""

from __future__ import annotations

import sys

from .cli.main import main

if __name__ == "__main__":
    sys.exit(main())
