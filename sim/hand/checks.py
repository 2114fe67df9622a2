"""Behavioural checks of a registered object, for plugin authors.

Objects are MuJoCo primitives (sphere, cylinder, box) described by an
:class:`~sim.hand.objects.ObjectSpec`. :func:`check_object` builds the registered
object and the hand model around it, and checks, in order (a failure of ``spec`` or
``model`` stops the checks that need it):

``spec``
    ``make_object(name)`` returns a valid :class:`~sim.hand.objects.ObjectSpec`: its
    factory runs and every parameter is finite and in range (mass, friction, width,
    height, contact softness, break force; validated again).
``name``
    The spec is named as it is registered (its MuJoCo body and the rows carry the name).
``repeatable``
    Two calls give the same spec (the scenario seeds assume a name means one object).
``model``
    The hand model compiles with the object (:func:`sim.hand.model.build_model`).
``mass``
    The compiled object body has the spec's mass, within :data:`MASS_RTOL`.
``inertia``
    Its principal moments of inertia are positive and satisfy the triangle inequality:
    the geometry encloses a solid.
``rests``
    Left on the table with the hand open for :data:`REST_S`, the object stays finite,
    its centre within :data:`REST_TOLERANCE` of its half-height of where it was placed,
    and it ends slower than :data:`REST_SPEED_M_S` (it neither sinks, falls through the
    table nor jumps).

Each returns :class:`sim.checks.CheckFailure` records, one line each.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from sim.checks import CheckFailure, raised
from sim.hand.objects import ObjectSpec, make_object

#: Relative tolerance of the compiled mass.
MASS_RTOL = 1e-6
#: Time the object is left on the table, s.
REST_S = 0.5
#: Largest settling of the object's centre, as a fraction of its half-height (a soft
#: object sinks into the table under its own weight).
REST_TOLERANCE = 0.25
#: Largest speed of the object's centre at the end of the rest, m/s.
REST_SPEED_M_S = 0.05

_FAMILY = "object"


def check_object(name: str) -> list[CheckFailure]:
    """Check the registered object ``name`` (the checks of the module docstring).

    Parameters
    ----------
    name : str
        A registered object (:func:`sim.hand.objects.object_names`).

    Returns
    -------
    list of CheckFailure
        One per failed check; empty when the object passes.

    Raises
    ------
    sim.hand.objects.ObjectSpecError
        ``name`` is not registered.
    """
    from sim.hand.objects import ObjectSpecError, object_names

    if name not in object_names():
        raise ObjectSpecError(f"object name: expected one of {', '.join(object_names())}, "
                              f"found {name!r}")
    try:
        spec = make_object(name)
        if not isinstance(spec, ObjectSpec):
            return [_failure(name, "spec", "its factory to return an ObjectSpec",
                             f"a {type(spec).__name__}")]
        spec = dataclasses.replace(spec)  # validated again
    except Exception as exc:  # a plugin's factory may raise anything: that is the finding
        return [_failure(name, "spec", "a valid ObjectSpec (finite parameters in range)",
                         raised(exc))]
    failures = []
    if spec.name != name:
        failures.append(_failure(name, "name", f"the spec named {name!r}", repr(spec.name)))
    try:
        again: Any = make_object(name)
    except Exception as exc:
        again = raised(exc)
    if again != spec:
        failures.append(_failure(name, "repeatable", "the same spec from every call",
                                 f"{again} after {spec}"))
    return failures + _check_model(name, spec)


def _failure(name: str, check: str, expected: str, found: str) -> CheckFailure:
    return CheckFailure(_FAMILY, name, check, expected, found)


def _check_model(name: str, spec: ObjectSpec) -> list[CheckFailure]:
    """``model``, ``mass``, ``inertia`` and ``rests``."""
    from sim.hand.model import build_model

    try:
        model = build_model(spec)
    except Exception as exc:
        return [_failure(name, "model", "the hand model to compile with the object",
                         raised(exc))]
    body = model.body("object").id
    failures = []
    mass_kg = float(model.body_mass[body])
    if not np.isclose(mass_kg, spec.mass_kg, rtol=MASS_RTOL, atol=0.0):
        failures.append(_failure(name, "mass", f"a body of {spec.mass_kg:g} kg (within "
                                 f"{MASS_RTOL:g})", f"{mass_kg:g} kg"))
    inertia = np.sort(np.asarray(model.body_inertia[body], dtype=float))
    if not (np.all(inertia > 0) and inertia[0] + inertia[1] >= inertia[2] * (1 - 1e-9)):
        failures.append(_failure(name, "inertia", "positive principal moments with "
                                 "I1 + I2 >= I3 (a closed solid)",
                                 f"{np.round(inertia, 9).tolist()} kg m^2"))
    return failures + _check_rest(name, spec, model, body)


def _check_rest(name: str, spec: ObjectSpec, model: Any, body: int) -> list[CheckFailure]:
    """``rests``: the object left on the table with the hand open."""
    import mujoco

    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    placed = data.xpos[body].copy()
    try:
        for _ in range(int(round(REST_S / model.opt.timestep))):
            mujoco.mj_step(model, data)
    except Exception as exc:
        return [_failure(name, "rests", "the object to rest on the table", raised(exc))]
    position = data.xpos[body]
    speed = float(np.linalg.norm(data.cvel[body][3:]))
    expected = (f"its centre within {REST_TOLERANCE:g} x {spec.half_height_m:g} m of "
                f"{placed[2]:.4g} m and slower than {REST_SPEED_M_S:g} m/s after {REST_S:g} s")
    if not (np.all(np.isfinite(position)) and np.isfinite(speed)):
        return [_failure(name, "rests", expected, "a non-finite position or speed")]
    sink = abs(float(position[2] - placed[2]))
    if sink > REST_TOLERANCE * spec.half_height_m or speed > REST_SPEED_M_S:
        return [_failure(name, "rests", expected,
                         f"height {position[2]:.4g} m, speed {speed:.3g} m/s")]
    return []
