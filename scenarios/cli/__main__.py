"""``python -m scenarios.cli``: the ``griploop`` command line."""

import sys

from scenarios.cli.main import main

sys.exit(main())
