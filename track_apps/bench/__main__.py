"""``python -m track_apps.bench`` = ``track bench``."""

import sys

from track_apps.cli.bench import main

sys.exit(main())
