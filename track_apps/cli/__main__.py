"""``python -m track_apps.cli`` = ``track``."""

import sys

from track_apps.cli import main

sys.exit(main())
