"""``python -m hybobs_opt.cli ARGS``: the ``hybobs`` command."""

import sys

from . import main

sys.exit(main())
