"""The common base of every error griploop raises on purpose.

:class:`GriploopError` lives in ``sim`` because ``sim`` is the layer every other
package may import. Each specific error subclasses it *and* the built-in it
stands for (``class RecordingError(GriploopError, ValueError)``), so callers can
catch either. The command line turns a :class:`GriploopError` into one line on
stderr; any other exception is a bug and is reported as such.
"""


class GriploopError(Exception):
    """Bad input, an impossible specification or a failed computation, said in one line."""
