"""``python -m scenarios.cli``: the ``griploop`` command line."""

from scenarios.cli.main import entry

entry()
