"""``python -m scenarios.cli``: the ``griploop`` command line."""

from scenarios.cli.main import entry

if __name__ == "__main__":  # importing the module (the API reference does) runs nothing
    entry()
