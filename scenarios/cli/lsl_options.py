"""Command-line options that pin an LSL stream: ``--lsl NAME[@HOST]``, ``--lsl-source-id``.

Shared by ``live`` and ``calibrate``. The library (:mod:`scenarios.live.lsl`) says what
it expected without naming flags; :func:`stream_query` and :func:`resolve_pinned` add
the flags that fix each refusal.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from scenarios.cli.errors import UsageError
from scenarios.live.errors import AmbiguousStreamError, RemoteStreamError, StreamSpecError


def add_stream_options(p: argparse.ArgumentParser, *, imu_help: str) -> None:
    """Add ``--lsl``, ``--lsl-source-id``, ``--imu-lsl``, ``--imu-source-id`` and
    ``--allow-remote``."""
    p.add_argument("--lsl", required=True, metavar="NAME[@HOST]",
                   help="name of the sEMG LSL stream; NAME@HOST takes it only from that host")
    p.add_argument("--lsl-source-id", default=None, metavar="ID",
                   help="take the sEMG stream with this source_id (when several share the name: "
                   "the refusal lists each one's)")
    p.add_argument("--imu-lsl", default=None, metavar="NAME[@HOST]", help=imu_help)
    p.add_argument("--imu-source-id", default=None, metavar="ID",
                   help="take the IMU stream with this source_id")
    p.add_argument("--allow-remote", action="store_true",
                   help="accept streams from another host (LSL has no authentication: only on a "
                   "lab network you trust)")


def stream_query(args: argparse.Namespace, which: str, name: str | None = None) -> Any:
    """The :class:`~scenarios.live.lsl.StreamQuery` of ``--lsl`` and ``--lsl-source-id``
    (``which="lsl"``) or of ``--imu-lsl`` and ``--imu-source-id`` (``which="imu"``);
    ``name`` stands in for the name flag's value.

    Raises
    ------
    UsageError
        A value of the wrong form, naming the flag and the expected form.
    """
    import dataclasses

    from scenarios.live.lsl import StreamQuery, check_source_id

    flag, sid_flag = _flags(which)
    value = name if name is not None else getattr(args, "lsl" if which == "lsl" else "imu_lsl")
    source_id = getattr(args, "lsl_source_id" if which == "lsl" else "imu_source_id")
    try:
        query = StreamQuery.parse(value, allow_remote=args.allow_remote)
    except StreamSpecError as exc:
        raise UsageError(f"{flag}: {exc}") from None
    if source_id is None:
        return query
    try:
        return dataclasses.replace(query, source_id=check_source_id(source_id))
    except StreamSpecError as exc:
        raise UsageError(f"{sid_flag}: {exc}") from None


def resolve_pinned(queries: Sequence[tuple[Any, str, str]], timeout_s: float, *,
                   optional: Sequence[str] = ()) -> list[Any]:
    """:func:`scenarios.live.lsl.resolve_streams`, its refusals ending with the flags that help.

    Parameters
    ----------
    queries : sequence of (StreamQuery, which, what)
        Each stream: its query, ``"lsl"``, ``"imu"`` or ``"force"`` (whose flags), what
        it is.
    timeout_s : float
        How long to look, s.
    optional : sequence of str
        Names that need not exist (``None`` in their place).

    Raises
    ------
    AmbiguousStreamError, RemoteStreamError, StreamNotFoundError
        One line each.
    """
    from scenarios.live.lsl import resolve_streams

    try:
        return resolve_streams([q for q, _, _ in queries], timeout_s,
                               whats=[what for _, _, what in queries], optional=optional)
    except AmbiguousStreamError as exc:
        query, which = _refused(queries, str(exc))
        flag, sid_flag = _flags(which)
        how = f"{flag} {query.name}@HOST" + (f" or {sid_flag} ID" if sid_flag else "")
        raise AmbiguousStreamError(f"{exc} ({how})") from None
    except RemoteStreamError as exc:
        raise RemoteStreamError(f"{exc} (--allow-remote)") from None


def _refused(queries: Sequence[tuple[Any, str, str]], message: str) -> tuple[Any, str]:
    """The query an ambiguity refusal is about: the one its message quotes."""
    for query, which, what in queries:
        if f"LSL {what}s match {query}" in message:
            return query, which
    return queries[0][0], queries[0][1]


def _flags(which: str) -> tuple[str, str]:
    return {"lsl": ("--lsl", "--lsl-source-id"), "imu": ("--imu-lsl", "--imu-source-id"),
            "force": ("--force-lsl", "")}[which]
