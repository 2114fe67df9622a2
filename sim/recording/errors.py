"""The recording loader's error, and the layout options that get past it.

A :class:`RecordingError` names the source (file or argument), the field and what
was expected versus what was found. Where a layout option of
:func:`~sim.recording.load_recording` is at fault or would fix the file's reading,
the error also carries it as data: ``RecordingError.option`` (the option whose
value was refused) and ``RecordingError.fixes`` (what to set instead). Its
message says them in the library's terms (``set time_unit='ms'``); a front end says
them in its own (the command line's ``pass --time-unit ms``,
:mod:`scenarios.cli.recording_options`), from ``RecordingError.detail``, the
message without them.

Options are named as the keys of a column-map file (:data:`OPTIONS`):
``time_column``, ``emg_columns`` and ``force_column`` for the three fields of a
:class:`~sim.recording.ColumnMap`, the others as the keyword arguments of
``load_recording``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from sim.errors import GriploopError

#: Layout options, named as column-map keys (``fs_hz`` is ``load_recording(fs_hz=...)``).
OPTIONS = ("time_column", "emg_columns", "force_column", "time_unit", "fs_hz", "emg_unit",
           "resample_hz", "duplicates")
#: Options naming a column, whose value ``"none"`` means "no such column" (``None`` in Python).
COLUMN_OPTIONS = ("time_column", "emg_columns", "force_column")


@dataclass(frozen=True)
class Fix:
    """One way past a loading error: layout options to set together.

    Attributes
    ----------
    settings : tuple of (option, value)
        Each option (one of :data:`~sim.recording.errors.OPTIONS`) and the value to give it, as text
        (``"ms"``, ``"time_s"``; ``"none"`` for no such column), or ``None`` when
        the caller must choose it (a rate, a column name).
    when : str
        When this fix applies (``"if the file has no time column"``), or ``""``.
    """

    settings: tuple[tuple[str, str | None], ...]
    when: str = ""

    def __post_init__(self) -> None:
        unknown = [option for option, _ in self.settings if option not in OPTIONS]
        if unknown or not self.settings:
            raise ValueError(f"Fix: expected options among {OPTIONS}, found {unknown or 'none'}")

    @classmethod
    def set(cls, option: str, value: str | None = None, *, when: str = "") -> Fix:
        """The fix that sets one ``option`` (to ``value``, or to a value the caller chooses)."""
        return cls(((option, value),), when)

    def library_text(self) -> str:
        """The fix in ``load_recording``'s terms: ``time_column=None and fs_hz``."""
        parts = []
        for option, value in self.settings:
            if value is None:
                parts.append(option)
            elif value == "none" and option in COLUMN_OPTIONS:
                parts.append(f"{option}=None")
            else:
                parts.append(f"{option}={value!r}")
        return " and ".join(parts) + (f" {self.when}" if self.when else "")


class RecordingError(GriploopError, ValueError):
    """A recording file or array is malformed.

    The message names the source (file or argument), the column or field and
    what was expected versus what was found; then the layout option at fault and
    the options that would fix it, if any.

    Parameters
    ----------
    detail : str
        The message without the option and the fixes.
    option : str, optional
        The layout option (one of :data:`~sim.recording.errors.OPTIONS`) whose value was refused.
    fixes : sequence of Fix
        Ways past the error, most likely first.

    Attributes
    ----------
    detail, option, fixes
        As given (``fixes`` a tuple), for a front end that names options its own way.
    """

    def __init__(self, detail: str, *, option: str | None = None,
                 fixes: Sequence[Fix] = ()) -> None:
        if option is not None and option not in OPTIONS:
            raise ValueError(f"RecordingError: expected an option among {OPTIONS}, "
                             f"found {option!r}")
        self.detail = detail
        self.option = option
        self.fixes = tuple(fixes)
        super().__init__(detail + self.hint(str, Fix.library_text, "set"))

    def hint(self, name: Callable[[str], str], fix_text: Callable[[Fix], str], verb: str) -> str:
        """The option and fixes as a message suffix, in a front end's terms.

        Parameters
        ----------
        name : callable
            ``name(option) -> str``: how the front end names an option.
        fix_text : callable
            ``fix_text(fix) -> str``: how it says one :class:`Fix`.
        verb : str
            What introduces the fixes (``"set"``, ``"pass"``).

        Returns
        -------
        str
            ``" (option NAME); VERB FIX, or FIX"``, each part only when present.
        """
        text = f" (option {name(self.option)})" if self.option is not None else ""
        if self.fixes:
            text += f"; {verb} " + ", or ".join(fix_text(fix) for fix in self.fixes)
        return text
