"""``python -m imucalib.cli``: the ``imucalib`` command."""

from __future__ import annotations

import sys

from . import main

sys.exit(main())
