"""The conditions a board row runs: which benchmark, under which hand, user and feedback.

An :class:`Arm` is one condition of a finding (the prosthesis with vision only, the
intact hand, ...): a scenario kind with its library file's base
(``scenarios/library/*.yaml``), the dotted scenario paths the condition sets, and the
variants each subject runs (eggs of several break forces, rigid objects drawn per
subject). Every arm of the board runs the same subjects with the same seeds per subject
(:func:`subject_seed`), so two arms of a finding are paired.

:class:`BoardConfig` says under which clinical paradigm, estimator and decoder the
prosthesis runs (:func:`clinical`); the intact hand's arms (:func:`intact`) drive the
human-speed hand with the user's own force, felt by touch.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib.resources import files
from typing import Any

import numpy as np
import yaml

from scenarios.schema import derive_seed

EPISODE_BASE: dict[str, Any] = {
    "kind": "episode",
    "protocol": {"name": "grasp_lift_hold", "hold_s": 2.0},
    "controller": {"kind": "pid"},
    "user": {"kind": "reacting", "practice": 5},
}
"""A grasp-lift-hold episode of a practised user (the rigid-object trials)."""


@dataclass(frozen=True)
class BoardConfig:
    """What the board runs: how many subjects, the seed, and the prosthesis's interface.

    Attributes
    ----------
    subjects : int
        Virtual subjects 1..N of population 0.
    seed : int
        Every scenario's seed derives from it and the subject (:func:`subject_seed`).
    paradigm : str
        The prosthesis's paradigm (``velocity``, the clinical one, by default).
    estimator : str
        The force estimator (free run, sEMG only).
    decoder : str
        The open/close decoder of a paradigm that needs one.
    smoke : bool
        Shortened protocols and no practice: a check that the board is well formed,
        never a figure to read.
    """

    subjects: int = 10
    seed: int = 37
    paradigm: str = "velocity"
    estimator: str = "ss_kf"
    decoder: str = "pattern"
    smoke: bool = False

    @property
    def drive(self) -> str:
        """The clinical hands' self-locking drive, except under the paper's ``force``."""
        return "backdrivable" if self.paradigm == "force" else "self_locking"

    def condition(self) -> dict[str, Any]:
        """The prosthesis's interface, as a row's ``condition`` names it."""
        from controllers.paradigms import needs_decoder

        return {"paradigm": self.paradigm, "drive": self.drive, "estimator": self.estimator,
                "mode": "free_run", "controller": "pid",
                "decoder": self.decoder if needs_decoder(self.paradigm) else None}


@dataclass(frozen=True)
class Arm:
    """One condition of a finding (module notes).

    Attributes
    ----------
    kind : str
        Scenario kind with a library file (``transfers``, ``eggs``, ...) or ``episode``.
    settings : mapping
        Dotted scenario paths set on the base (``{"user.feedback": "touch"}``).
    variants : callable
        ``variants(subject_id) -> list of mappings``: what each subject runs, each a
        mapping of dotted paths (default: one scenario, nothing added).
    seed_per_variant : bool
        Variant ``i`` of a subject takes occurrence ``i`` of the subject's seed (objects
        drawn per subject); otherwise every variant shares the subject's seed.
    """

    kind: str
    settings: Mapping[str, Any]
    variants: Callable[[int], list[Mapping[str, Any]]] = field(default=lambda s: [{}])
    seed_per_variant: bool = False

    def scenarios(self, subjects: int, seed: int) -> list[tuple[int, dict[str, Any]]]:
        """``(subject_id, scenario mapping)`` for every subject and variant."""
        base = library_base(self.kind)
        out = []
        for subject in range(1, subjects + 1):
            for i, variant in enumerate(self.variants(subject)):
                data = _deep_copy(base)
                for path, value in {**self.settings, **variant}.items():
                    set_path(data, path, value)
                set_path(data, "subject.subject_id", subject)
                data["seed"] = subject_seed(seed, subject, i if self.seed_per_variant else 0)
                out.append((subject, data))
        return out


def subject_seed(seed: int, subject: int, occurrence: int = 0) -> int:
    """The seed of a subject's scenarios: the same in every arm (paired conditions)."""
    return derive_seed(seed, f"subject {subject}", occurrence)


def library_base(kind: str) -> dict[str, Any]:
    """The base scenario of a kind's library file (:data:`EPISODE_BASE` for episodes)."""
    if kind == "episode":
        return _deep_copy(EPISODE_BASE)
    text = (files("scenarios") / "library" / f"{kind}.yaml").read_text()
    return yaml.safe_load(text)["base"]


def set_path(node: dict[str, Any], path: str, value: Any) -> None:
    """Set the dotted ``path`` in a nested mapping (``None`` removes the key)."""
    parts = path.split(".")
    for part in parts[:-1]:
        node = node.setdefault(part, {})
    if value is None:
        node.pop(parts[-1], None)
    else:
        node[parts[-1]] = value


def _deep_copy(data: Any) -> Any:
    if isinstance(data, dict):
        return {k: _deep_copy(v) for k, v in data.items()}
    if isinstance(data, list):
        return [_deep_copy(v) for v in data]
    return data


def clinical(config: BoardConfig, **settings: Any) -> dict[str, Any]:
    """The prosthesis's scenario paths under ``config`` (practised user, free run), plus
    ``settings`` (underscores in keys stand for dots: ``user__feedback``)."""
    from controllers.paradigms import needs_decoder

    out: dict[str, Any] = {
        "controller.kind": "pid", "estimator.name": config.estimator,
        "estimator.mode": "free_run", "user.kind": "reacting",
        "paradigm": None if config.paradigm == "force" else config.paradigm,
        "hand.drive": None if config.drive == "backdrivable" else config.drive,
        "decoder": config.decoder if needs_decoder(config.paradigm) else None,
    }
    out.update(_smoke(config))
    out.update({k.replace("__", "."): v for k, v in settings.items()})
    return out


def intact(config: BoardConfig, **settings: Any) -> dict[str, Any]:
    """The intact hand's scenario paths: the human-speed hand driven by the user's own force,
    felt by touch (no sEMG path, no decoder, the paper's ``force`` paradigm)."""
    out: dict[str, Any] = {"controller.kind": "pid", "estimator.name": "intact",
                           "estimator.mode": "free_run", "user.kind": "reacting",
                           "user.feedback": "touch", **_smoke(config)}
    out.update({k.replace("__", "."): v for k, v in settings.items()})
    return out


def _smoke(config: BoardConfig) -> dict[str, Any]:
    """A smoke board's users do not practise (the protocols shorten in each finding)."""
    return {"user.practice": 0} if config.smoke else {}


def rigid_objects(config: BoardConfig) -> Callable[[int], list[Mapping[str, Any]]]:
    """Rigid everyday objects drawn per subject (two; one in a smoke board): a can of
    0.2-1.0 kg and friction 0.3-1.0 three times in four, the aluminium block once in four
    (the draw of benchmarks/closed_loop_verdicts.py), from the board's seed."""
    per_subject = 1 if config.smoke else 2

    def draw(subject: int) -> list[Mapping[str, Any]]:
        rng = np.random.default_rng(np.random.SeedSequence(config.seed, spawn_key=(subject,)))
        out: list[Mapping[str, Any]] = []
        for _ in range(per_subject):
            if rng.random() < 0.25:
                out.append({"object.name": "block"})
            else:
                out.append({"object.name": "can",
                            "object.mass_kg": round(float(rng.uniform(0.2, 1.0)), 2),
                            "object.friction": round(float(rng.uniform(0.3, 1.0)), 2)})
        return out

    return draw
