"""sEMG generators by name: :func:`~sim.user.generators.register_generator` and
:func:`~sim.user.generators.make_generator`.

========================  ===================================================
name                      generator
========================  ===================================================
noise                     amplitude-modulated noise (Hogan and Mann 1980),
                          :class:`sim.user.emg_noise.NoiseEmgGenerator`
motor_units               Fuglevand (1993) motor-unit pool,
                          :class:`sim.user.motor_units.MotorUnitEmgGenerator`
========================  ===================================================

A new generator is a module with a class satisfying
:class:`sim.user.emg.EmgGenerator` plus one call::

    register_generator("my_gen", "mypackage.my_gen:MyGenerator")

Registrations by ``"module:attribute"`` are imported when the generator is
first built, so listing the names imports no signal-processing code.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from sim.errors import GriploopError
from sim.registry import Registry

if TYPE_CHECKING:
    from collections.abc import Callable

    from sim.user.emg import EmgGenerator


class UnknownGeneratorError(GriploopError, LookupError):
    """A generator name that is not registered; the message lists the registered ones."""


_REGISTRY = Registry("generator", UnknownGeneratorError)


def register_generator(name: str, factory: Callable[..., EmgGenerator] | str, *,
                       replace: bool = False) -> None:
    """Register an sEMG generator.

    Parameters
    ----------
    name : str
        Name used by ``VirtualSubject.record(generator=...)``, scenarios
        (``subject.generator``) and the CLI.
    factory : callable or str
        ``factory(**settings) -> EmgGenerator`` (usually the class), or its
        ``"package.module:attribute"`` reference, imported on first use.
    replace : bool
        Allow replacing an existing registration.

    Raises
    ------
    sim.registry.RegistrationError
        Malformed reference, or ``name`` already registered.
    """
    _REGISTRY.register(name, factory, replace=replace)


unregister_generator, generator_names = _REGISTRY.functions(__name__, "generator")


def make_generator(generator: str | EmgGenerator, **settings: Any) -> EmgGenerator:
    """An sEMG generator from its registered name, or ``generator`` itself if not a name.

    Parameters
    ----------
    generator : str or EmgGenerator
        Registered name, or an object already satisfying :class:`sim.user.emg.EmgGenerator`.
    **settings
        Passed to the generator's factory (e.g. ``n_units=300`` for motor units).

    Raises
    ------
    UnknownGeneratorError
        For an unknown name; the message lists the registered names.
    """
    if not isinstance(generator, str):
        return generator
    return _REGISTRY.get(generator)(**settings)


def __getattr__(attr: str) -> Any:
    if attr == "GENERATORS":  # the names registered so far
        return generator_names()
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


register_generator("noise", "sim.user.emg_noise:NoiseEmgGenerator")
register_generator("motor_units", "sim.user.motor_units:MotorUnitEmgGenerator")
