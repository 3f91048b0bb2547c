"""``python -m lfd_track.cli``: the ``lfd-track`` command."""

import sys

from .parser import main

sys.exit(main())
