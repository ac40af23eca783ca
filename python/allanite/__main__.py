"""``python -m allanite`` runs the command line."""

import sys

from allanite.cli import main

sys.exit(main())
