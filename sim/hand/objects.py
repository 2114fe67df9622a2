"""Graspable objects generated from parameters, and a small named library.

An :class:`ObjectSpec` describes one rigid or soft object resting on the table:
shape, size, mass, Coulomb friction, contact softness (MuJoCo ``solref`` /
``solimp``) and a fragility threshold. It is validated at construction; every
invalid field raises :class:`ObjectSpecError` naming the field, the value found
and the valid range.

Library defaults (CALIBRATION.md "Prosthetic hands"): the paper's anti-stress
ball (about 70 mm, soft), a soda can (0.386 kg, 66 mm x 122 mm), a paper cup
(light, crushes at a few newtons), an egg (about 0.06 kg; the Virtual Eggs Test
uses break forces of 0.4-11.5 N), an aluminium block (0.461 kg), the blocks of the
benchmarks and the Box and Blocks Test's 25 mm wooden cube (``bbt_cube``).

The library is a registry of object factories: a new object is a function
returning its :class:`ObjectSpec` plus one call,
``register_object("mug", "mypackage.mug:mug")``; :func:`make_object`, the scenario
schema and the CLI's ``--object`` then know it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from sim.errors import GriploopError
from sim.registry import Registry

SHAPES = ("sphere", "cylinder", "box")
MASS_RANGE_KG = (0.005, 2.0)
"""Object masses accepted, kg (the Box and Blocks Test's 25 mm wooden cube weighs about 9 g)."""
FRICTION_RANGE = (0.2, 1.5)
# Largest object the open hand can surround (inner gap about 0.16 m), and the
# smallest it can close on (fully closed, the digits cross at about 0 mm).
WIDTH_RANGE_M = (0.02, 0.12)
HEIGHT_RANGE_M = (0.02, 0.25)


class ObjectSpecError(GriploopError, ValueError):
    """An object parameter is outside its valid range or of the wrong kind."""


@dataclass(frozen=True)
class ObjectSpec:
    """Parameters of one graspable object.

    Parameters
    ----------
    name : str
        Label used for the MuJoCo body (``"object"`` geoms are named after it).
    shape : {"sphere", "cylinder", "box"}
        Geometry.
    size_m : tuple of float
        Sphere: ``(radius,)``; cylinder: ``(radius, half_height)``; box:
        ``(half_x, half_y, half_z)``. Metres, MuJoCo's half-size convention.
    mass_kg : float
        Mass in kg, within 0.005..2.
    friction : float
        Sliding (Coulomb) friction coefficient, within 0.2..1.5. The object geom
        has contact priority, so this is the coefficient of every hand-object and
        object-table contact.
    solref : tuple of float
        MuJoCo contact ``(timeconst_s, dampratio)``; larger timeconst is softer.
    solimp : tuple of float
        MuJoCo contact impedance ``(dmin, dmax, width_m)``; a low ``dmin`` and
        wide ``width_m`` give a soft, progressively stiffening contact.
    break_force_n : float or None
        Grip force in N above which the object is crushed; ``None`` means
        unbreakable.
    rgba : tuple of float
        Display colour.
    """

    name: str
    shape: str
    size_m: tuple[float, ...]
    mass_kg: float
    friction: float = 1.0
    solref: tuple[float, float] = (0.004, 1.0)
    solimp: tuple[float, float, float] = (0.95, 0.99, 0.001)
    break_force_n: float | None = None
    rgba: tuple[float, float, float, float] = (0.8, 0.5, 0.2, 1.0)

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ObjectSpecError(f"shape: expected one of {SHAPES}, found {self.shape!r}")
        n_size = {"sphere": 1, "cylinder": 2, "box": 3}[self.shape]
        size = tuple(float(s) for s in self.size_m)
        object.__setattr__(self, "size_m", size)
        if len(size) != n_size:
            raise ObjectSpecError(
                f"size_m: a {self.shape} needs {n_size} half-sizes, found {len(size)} ({size})"
            )
        if not all(math.isfinite(s) and s > 0 for s in size):
            raise ObjectSpecError(f"size_m: expected positive finite sizes, found {size}")
        _check_range("mass_kg", self.mass_kg, MASS_RANGE_KG)
        _check_range("friction", self.friction, FRICTION_RANGE)
        _check_range("width_m", self.width_m, WIDTH_RANGE_M)
        _check_range("height_m", self.height_m, HEIGHT_RANGE_M)
        if len(self.solref) != 2 or not (0.002 <= self.solref[0] <= 0.2 and self.solref[1] > 0):
            raise ObjectSpecError(
                f"solref: expected (timeconst_s in 0.002..0.2, dampratio > 0), found {self.solref}"
            )
        if len(self.solimp) != 3 or not (
            0 < self.solimp[0] <= self.solimp[1] < 1 and self.solimp[2] > 0
        ):
            raise ObjectSpecError(
                f"solimp: expected (dmin, dmax, width_m) with 0 < dmin <= dmax < 1 and "
                f"width_m > 0, found {self.solimp}"
            )
        if self.break_force_n is not None and not (
            math.isfinite(self.break_force_n) and self.break_force_n > 0
        ):
            raise ObjectSpecError(
                f"break_force_n: expected a positive force in N or None, found "
                f"{self.break_force_n!r}"
            )
        if len(self.rgba) != 4:
            raise ObjectSpecError(f"rgba: expected 4 values, found {self.rgba}")

    @property
    def width_m(self) -> float:
        """Extent along the grasp axis (x) in metres."""
        return 2.0 * self.size_m[0]

    @property
    def half_height_m(self) -> float:
        """Half of the vertical extent in metres (rest height of the centre)."""
        return {"sphere": self.size_m[0], "cylinder": self.size_m[-1], "box": self.size_m[-1]}[
            self.shape
        ]

    @property
    def height_m(self) -> float:
        """Vertical extent in metres."""
        return 2.0 * self.half_height_m

    @property
    def breakable(self) -> bool:
        """Whether the object has a finite break force."""
        return self.break_force_n is not None

    def replace(self, **overrides: Any) -> ObjectSpec:
        """A copy with some fields replaced (validated again)."""
        return dataclasses.replace(self, **overrides)


def _check_range(field: str, value: float, bounds: tuple[float, float]) -> None:
    lo, hi = bounds
    ok = isinstance(value, (int, float)) and math.isfinite(value) and lo <= value <= hi
    if not ok:
        raise ObjectSpecError(f"{field}: expected a number in {lo}..{hi}, found {value!r}")


_SOFT_SOLREF = (0.02, 1.0)
_SOFT_SOLIMP = (0.3, 0.95, 0.01)

_REGISTRY = Registry("object", ObjectSpecError)


def register_object(name: str, factory: Callable[[], ObjectSpec] | str, *,
                    replace: bool = False) -> None:
    """Register a library object.

    Parameters
    ----------
    name : str
        Name used by :func:`make_object`, scenarios (``object.name``), sweeps
        and the CLI (``--object``).
    factory : callable or str
        ``factory() -> ObjectSpec`` (the object's default parameters), or its
        ``"package.module:attribute"`` reference, imported on first use.
    replace : bool
        Allow replacing an existing registration.

    Raises
    ------
    sim.registry.RegistrationError
        Malformed reference, or ``name`` already registered.
    """
    _REGISTRY.register(name, factory, replace=replace)


unregister_object, object_names = _REGISTRY.functions(__name__, "object")


def library() -> dict[str, ObjectSpec]:
    """Every registered object with its default parameters: ``name -> ObjectSpec``."""
    return {name: _REGISTRY.get(name)() for name in _REGISTRY.names()}


def __getattr__(attr: str) -> Any:
    if attr == "LIBRARY":  # the objects registered so far
        return library()
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


def _ball() -> ObjectSpec:
    """The paper's anti-stress ball: 70 mm foam, squeezes by ~10 mm at 20 N."""
    return ObjectSpec("ball", "sphere", (0.035,), 0.05, friction=1.0, solref=_SOFT_SOLREF,
                      solimp=_SOFT_SOLIMP, rgba=(0.85, 0.2, 0.2, 1.0))


def _can() -> ObjectSpec:
    """Soda can: 0.386 kg, 66 mm x 122 mm, rigid aluminium."""
    return ObjectSpec("can", "cylinder", (0.033, 0.061), 0.386, friction=0.5,
                      rgba=(0.75, 0.75, 0.8, 1.0))


def _cup() -> ObjectSpec:
    """Paper cup: 75 mm x 90 mm, 20 g (a paper cup weighs about 10 g; 20 g was the mass range's
    lower bound when it was made, kept so that no figure moves), crushes at ~4 N."""
    return ObjectSpec("cup", "cylinder", (0.0375, 0.045), 0.02, friction=0.8,
                      solref=(0.01, 1.0), solimp=(0.8, 0.95, 0.003), break_force_n=4.0,
                      rgba=(0.95, 0.95, 0.9, 1.0))


def _egg() -> ObjectSpec:
    """Egg: ~0.06 kg, 45 mm x 57 mm (a sphere of the short axis), breaks at 5 N.

    The Virtual Eggs Test spans 0.4-11.5 N.
    """
    return ObjectSpec("egg", "sphere", (0.0225,), 0.06, friction=0.6, break_force_n=5.0,
                      rgba=(0.95, 0.9, 0.75, 1.0))


def _block() -> ObjectSpec:
    """Aluminium block 0.461 kg: 60 x 50 x 57 mm -> 2.7 g/cm^3 * 171 cm^3."""
    return ObjectSpec("block", "box", (0.03, 0.025, 0.0285), 0.461, friction=0.6,
                      rgba=(0.6, 0.62, 0.66, 1.0))


def _vet_block() -> ObjectSpec:
    """A Virtual Eggs Test block: a light 50 mm cube that breaks at its threshold (default 4 N).

    The test's 11 eggs break at 0.4-11.5 N (Controzzi et al.); their mass is not
    published as far as we know: 30 g and friction 0.8 are our choice.
    """
    return ObjectSpec("vet_block", "box", (0.025, 0.025, 0.025), 0.03, friction=0.8,
                      break_force_n=4.0, rgba=(0.95, 0.85, 0.3, 1.0))


def _transfer_block() -> ObjectSpec:
    """A block for timed transfers: a 50 mm wooden cube of 30 g (griploop's variant).

    The Box and Blocks Test's blocks are 25 mm cubes (:func:`_bbt_cube`, the default of
    ``griploop transfers``); this larger block, as the Virtual Eggs Test's, was the
    transfers' block while the hand met a 25 mm cube on its top edges. 30 g and friction
    0.6 (wood on the pads) are our choice. It does not break (override ``break_force_n``
    for a fragile block).
    """
    return ObjectSpec("transfer_block", "box", (0.025, 0.025, 0.025), 0.03, friction=0.6,
                      rgba=(0.2, 0.45, 0.8, 1.0))


BBT_CUBE_EDGE_M = 0.025
"""Edge of the Box and Blocks Test's cubes, m: "2.5 cm" wooden blocks (Mathiowetz et al. 1985,
Am J Occup Ther 39:386)."""
WOOD_DENSITY_KG_M3 = 650.0
"""Density of the test's wooden cubes, kg/m^3: the middle of 0.60-0.70, the specific weight of
kiln-dried "heavy woods" (maple, beech, birch, ash; Roth 1895, US Forest Service Bulletin 10,
p. 28, as tabulated in Noyes, *Wood and Forest*). The test's sources name no species: a
hardwood is our assumption; the range gives 9.4-10.9 g for the cube."""
BBT_CUBE_FRICTION = 0.6
"""Friction of the painted wooden cube on the silicone pads (and on the table). No published
coefficient for that pair was found: 0.6 is our choice, the project's wood-on-pad value (the
``transfer_block``'s), of the order measured for fingertip skin on a smooth rigid material
(0.6 on aluminium, averaged over 1-20 N; Seo et al. 2009, Ergonomics 52:609)."""


def _bbt_cube() -> ObjectSpec:
    """The Box and Blocks Test's block: a 25 mm wooden cube of ``edge^3 x density`` (10.2 g).

    Mass from :data:`BBT_CUBE_EDGE_M` and :data:`WOOD_DENSITY_KG_M3`, friction
    :data:`BBT_CUBE_FRICTION`; it does not break. The hand meets a box this small on its
    sides with its fingertips (:func:`sim.hand.model.approach_height_m`).
    """
    half = 0.5 * BBT_CUBE_EDGE_M
    return ObjectSpec("bbt_cube", "box", (half, half, half),
                      BBT_CUBE_EDGE_M ** 3 * WOOD_DENSITY_KG_M3, friction=BBT_CUBE_FRICTION,
                      rgba=(0.85, 0.25, 0.2, 1.0))


for _name, _factory in (("ball", _ball), ("can", _can), ("cup", _cup), ("egg", _egg),
                        ("block", _block), ("vet_block", _vet_block),
                        ("transfer_block", _transfer_block), ("bbt_cube", _bbt_cube)):
    register_object(_name, _factory)


def make_object(name: str = "ball", **overrides: Any) -> ObjectSpec:
    """A library object with any parameter overridden.

    Parameters
    ----------
    name : str
        A registered object (:func:`object_names`: ``ball``, ``can``, ``cup``,
        ``egg``, ``block``, ...).
    **overrides
        Any :class:`ObjectSpec` field, e.g. ``mass_kg=0.4, friction=0.5``.

    Returns
    -------
    ObjectSpec
        Validated specification.

    Raises
    ------
    ObjectSpecError
        Unknown name, unknown field or invalid value.

    Examples
    --------
    >>> make_object("can", mass_kg=0.4, friction=0.5).mass_kg
    0.4
    """
    if name not in _REGISTRY:
        raise ObjectSpecError(
            f"object name: expected one of {sorted(object_names())}, found {name!r}")
    fields = {f.name for f in dataclasses.fields(ObjectSpec)}
    unknown = sorted(set(overrides) - fields)
    if unknown:
        raise ObjectSpecError(
            f"object field: unknown {unknown}; expected a subset of {sorted(fields)}"
        )
    return _REGISTRY.get(name)().replace(**overrides)


def as_object_spec(obj: ObjectSpec | str | dict[str, Any]) -> ObjectSpec:
    """Coerce a spec, a library name, or a dict ``{"name": ..., **overrides}``."""
    if isinstance(obj, ObjectSpec):
        return obj
    if isinstance(obj, str):
        return make_object(obj)
    if isinstance(obj, dict):
        params = dict(obj)
        base = params.pop("name", "ball")
        return make_object(base, **params)
    raise ObjectSpecError(
        f"object: expected an ObjectSpec, a library name or a dict, found {type(obj).__name__}"
    )
