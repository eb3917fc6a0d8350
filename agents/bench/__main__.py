"""``python -m agents.bench`` = ``track-bench``."""

import sys

from agents.bench.cli import main

sys.exit(main())
