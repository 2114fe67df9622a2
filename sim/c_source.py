"""C99 source text shared by the exporters of the estimator and of the controller.

griploop exports what it evaluated as plain C for a prosthesis microcontroller
(``griploop export-c``, :mod:`scenarios.deploy`). The estimator's emitters live in
:mod:`estimation.export_c`, the controller's in :mod:`controllers.export_c`; both
write their coefficients with the helpers here, so that every table is a
``static const`` array of the same real type, every file names the griploop
version and a digest of the model it holds, and nothing non-finite or unstable
reaches a file.

Numbers are written with 17 significant digits: a literal parses to exactly the
float64 coefficient griploop computed with, and a float32 build (the default,
``gl_real`` is ``float``) rounds it once, at compile time, the way
``numpy.float32`` does.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sim.errors import GriploopError
from sim.registry import Registry

#: The header every exported file includes: the real type, the math it uses, the version.
TYPES_HEADER = "griploop_types.h"


class ExportError(GriploopError, ValueError):
    """A model or controller cannot be exported to C (kind, coefficients or stability)."""


class EmitterRegistry(Registry):
    """The C emitters of one family (estimators or controllers), by the name they export.

    Each exporter (:mod:`estimation.export_c`, :mod:`controllers.export_c`) keeps one and
    refuses a name without an emitter through :meth:`check`, before anything is fitted
    or designed.

    Parameters
    ----------
    family : str
        What is exported, singular (``"estimator"``), for messages.
    error : type of Exception
        Raised for a name without an emitter (the family's ``...NotExportableError``).
    """

    def __init__(self, family: str, error: type[Exception]) -> None:
        super().__init__(f"C export of {family}", error)
        self.family = family

    def check(self, name: str) -> None:
        """Refuse ``name`` unless it has an emitter.

        Raises
        ------
        error
            One line naming what can be exported: ``estimator 'narx' cannot be exported
            to C; exportable estimators: ss_kf, ...``.
        """
        if name not in self:
            raise self.unknown_error(
                f"{self.family} {name!r} cannot be exported to C; exportable "
                f"{self.family}s: {', '.join(self.names())}")

    def emitter(self, name: str) -> Any:
        """The emitter registered for ``name`` (imported on first use), checked first."""
        self.check(name)
        return self.get(name)


def griploop_version() -> str:
    """The installed griploop version, or ``unknown``."""
    from importlib import metadata

    try:
        return metadata.version("griploop")
    except metadata.PackageNotFoundError:
        return "unknown"


def model_digest(kind: str, tables: Mapping[str, np.ndarray],
                 constants: Mapping[str, Any]) -> str:
    """SHA-256 (first 16 hex digits) of a model: its kind, constants and float64 tables."""
    h = hashlib.sha256(kind.encode())
    h.update(json.dumps({k: constants[k] for k in sorted(constants)}, default=str).encode())
    for name in sorted(tables):
        values = np.ascontiguousarray(tables[name], dtype="<f8")
        h.update(f"{name}{values.shape}".encode())
        h.update(values.tobytes())
    return h.hexdigest()[:16]


def check_finite(who: str, tables: Mapping[str, np.ndarray]) -> None:
    """Refuse a table with a NaN, an infinity, or a value beyond float32's range.

    Raises
    ------
    ExportError
        Names the table and its first offending value.
    """
    for name, values in tables.items():
        v = np.asarray(values, dtype=np.float64)
        bad = ~np.isfinite(v) | (np.abs(v) > np.finfo(np.float32).max)
        if bad.any():
            raise ExportError(f"{who}: coefficient table {name} holds a non-finite value "
                              f"({v[bad].ravel()[0]!r}); expected finite float32 numbers")


def check_stable(who: str, state_matrix: np.ndarray, *, allow_unit: bool = False) -> float:
    """Spectral radius of a state matrix; refuse it if the recursion would grow.

    Parameters
    ----------
    who : str
        What the matrix belongs to, for the message.
    state_matrix : ndarray, shape (n, n)
        May be empty (a static map).
    allow_unit : bool
        Accept eigenvalues on the unit circle (a controller's integrator);
        otherwise the radius must be below 1.

    Raises
    ------
    ExportError
        Radius >= 1 (or > 1 with ``allow_unit``).
    """
    F = np.atleast_2d(np.asarray(state_matrix, dtype=np.float64))
    if F.size == 0:
        return 0.0
    check_finite(who, {"state matrix": F})
    radius = float(np.max(np.abs(np.linalg.eigvals(F))))
    limit_ok = radius <= 1.0 + 1e-9 if allow_unit else radius < 1.0
    if not limit_ok:
        bound = "at most 1" if allow_unit else "below 1"
        raise ExportError(f"{who}: state matrix has spectral radius {radius:.6g}; expected "
                          f"{bound} (an unstable recursion is not exported)")
    return radius


def c_number(x: float) -> str:
    """A C literal that parses to exactly the float64 ``x``."""
    x = float(x)
    text = f"{x:.17g}"
    return text if any(c in text for c in ".eEn") else text + ".0"


def c_table(name: str, values: Any, *, ctype: str = "gl_real", per_line: int = 4) -> str:
    """``static const <ctype> name[N] = {...};`` of ``values`` flattened in C (row-major) order.

    A 2-D table's shape is stated in a comment; integer types are written as integers.
    """
    v = np.asarray(values)
    flat = v.ravel()
    if flat.size == 0:  # C99 has no empty arrays: one unused zero
        flat = np.zeros(1)
    integer = not ctype.endswith("real") and ctype not in ("float", "double")
    items = [str(int(x)) if integer else c_number(x) for x in flat]
    lines = [", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line)]
    shape = "" if v.ndim < 2 else f"  /* shape {' x '.join(str(s) for s in v.shape)}, row-major */"
    body = ",\n    ".join(lines)
    return f"static const {ctype} {name}[{len(items)}] = {{{shape}\n    {body}\n}};"


@dataclass(frozen=True)
class CModel:
    """What an emitter produced: the C files of one model and what describes them.

    Attributes
    ----------
    kind : str
        The C family (``"lti"``, ``"mlp"``, ``"scheduled_pid"``, ...).
    files : dict of str to str
        File name to C text.
    digest : str
        :func:`model_digest` of the tables.
    summary : dict
        JSON-ready facts: sizes, rates, what the state holds.
    """

    kind: str
    files: dict[str, str]
    digest: str
    summary: dict[str, Any] = field(default_factory=dict)


def template_env(package: str, folder: str = "templates") -> Any:
    """A Jinja2 environment for C templates in ``package/folder``, with ``c_number``/``c_table``."""
    import jinja2

    env = jinja2.Environment(loader=jinja2.PackageLoader(package, folder),
                             undefined=jinja2.StrictUndefined, trim_blocks=True,
                             lstrip_blocks=True, keep_trailing_newline=True, autoescape=False)
    env.filters["c_number"] = c_number
    env.globals["c_table"] = c_table
    return env


def render(package: str, template: str, **context: Any) -> str:
    """Render one C template of ``package`` (its ``templates`` folder) with ``context``."""
    context.setdefault("version", griploop_version())
    return _env(package).get_template(template).render(**context)


_ENVS: dict[str, Any] = {}


def _env(package: str) -> Any:
    if package not in _ENVS:
        _ENVS[package] = template_env(package, "templates" if package != "sim" else "c_templates")
    return _ENVS[package]


def types_header(*, digests: Sequence[str]) -> str:
    """The text of ``griploop_types.h`` (real type, square root, exponential, version)."""
    return render("sim", "griploop_types.h.j2", digests=list(digests))
