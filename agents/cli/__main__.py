"""``python -m agents.cli`` = ``track``."""

import sys

from agents.cli import main

sys.exit(main())
