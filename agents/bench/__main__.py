"""``python -m agents.bench`` = ``track bench``."""

import sys

from agents.cli.bench import main

sys.exit(main())
