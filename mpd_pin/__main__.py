"""``python -m mpd_pin`` runs the ``mpd-pin`` command."""

import sys

from .app.cli import main

sys.exit(main())
