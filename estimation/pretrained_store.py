"""Pretrained networks as files: the weights (NPZ) and what made them (JSON).

:func:`estimation.transfer.pretrained` keeps every ensemble it builds in the cache
(``$GRIPLOOP_CACHE_DIR/pretrained``) and, first, looks for it among the networks shipped
in the package (``estimation/pretrained``, written by ``make pretrained`` for the default
settings). Either file is used only if its JSON states exactly the settings asked for,
including the digest of the source that builds them, and its arrays have the expected
shapes and finite values; anything else is a miss, never trusted.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
from scipy.special import expit

from sim.cache import write_atomic

#: The package folder of the shipped networks (``make pretrained`` writes it).
SHIPPED_DIR = Path(str(resources.files("estimation"))) / "pretrained"
#: Stem of every file: ``transfer_mlp-<key>.npz`` and ``.json``.
PREFIX = "transfer_mlp-"


@dataclass(frozen=True)
class Network:
    """Weights of one logistic MLP: ``coefs[l]`` (n_in, n_out) and ``intercepts[l]`` (n_out,)."""

    coefs: tuple[np.ndarray, ...]
    intercepts: tuple[np.ndarray, ...]

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Output for rows ``X`` (n_samples, n_in), shape (n_samples,)."""
        h = X
        last = len(self.coefs) - 1
        for i, (W, b) in enumerate(zip(self.coefs, self.intercepts, strict=True)):
            h = h @ W + b
            if i < last:
                h = expit(h)
        return h[:, 0]


@dataclass(frozen=True)
class Pretrained:
    """Pretrained networks and the fine-tuning settings chosen on virtual subjects.

    Attributes
    ----------
    networks : tuple of Network
    epochs : int
        Fine-tuning epochs chosen on the validation subjects.
    learning_rate : float
        Fine-tuning step size chosen there.
    info : dict
        Settings, corpus size, validation scores of every candidate, timing, key, and
        ``cache``: where this copy came from (``"memory"``, ``"shipped"``, ``"disk"``,
        ``"built"`` or ``"rebuilt: <reason>"``).
    """

    networks: tuple[Network, ...]
    epochs: int
    learning_rate: float
    info: dict


def save(path: Path, model: Pretrained) -> None:
    """Write ``model`` as ``path.npz`` (weights) and ``path.json`` (settings and choices)."""
    arrays = {}
    for k, net in enumerate(model.networks):
        for i, (W, b) in enumerate(zip(net.coefs, net.intercepts, strict=True)):
            arrays[f"net{k}_W{i}"] = W
            arrays[f"net{k}_b{i}"] = b
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    write_atomic(path.with_suffix(".npz"), buffer.getvalue())
    meta = {k: v for k, v in model.info.items() if k != "cache"}
    meta.update(epochs=model.epochs, learning_rate=model.learning_rate)
    write_atomic(path.with_suffix(".json"), json.dumps(meta, indent=1).encode())


def load(path: Path, settings: dict, key: str, epoch_stage: int) -> Pretrained:
    """Read a stored model; raise ``ValueError`` unless it is exactly what ``settings`` ask.

    ``key`` is the settings' key; the fine-tuning epochs must be a multiple of
    ``epoch_stage``.
    """
    meta = json.loads(path.with_suffix(".json").read_text())
    if any(meta.get(k) != v for k, v in settings.items()) or meta.get("key") != key:
        raise ValueError("settings differ")
    sizes = [settings["n_inputs"] * (settings["lags"] + 1), *settings["hidden"], 1]
    networks = []
    with np.load(path.with_suffix(".npz"), allow_pickle=False) as z:
        for k in range(settings["n_networks"]):
            coefs = tuple(np.array(z[f"net{k}_W{i}"], dtype=float) for i in range(len(sizes) - 1))
            intercepts = tuple(np.array(z[f"net{k}_b{i}"], dtype=float)
                               for i in range(len(sizes) - 1))
            for i, (W, b) in enumerate(zip(coefs, intercepts, strict=True)):
                if W.shape != (sizes[i], sizes[i + 1]) or b.shape != (sizes[i + 1],) \
                        or not (np.all(np.isfinite(W)) and np.all(np.isfinite(b))):
                    raise ValueError(f"network {k} layer {i} has the wrong shape or non-finite")
            networks.append(Network(coefs, intercepts))
    epochs, lr = int(meta["epochs"]), float(meta["learning_rate"])
    if epochs < 0 or epochs % epoch_stage or not lr > 0:
        raise ValueError("bad fine-tuning settings")
    return Pretrained(tuple(networks), epochs, lr, meta)


def read(path: Path, settings: dict, key: str, epoch_stage: int, *, found: str,
         missing: str = "built") -> tuple[Pretrained | None, str]:
    """The model at ``path`` (``info["cache"] = found``), or None and why not.

    A missing file gives ``missing``; an unusable one ``"rebuilt: <reason>"``.
    """
    if not (path.with_suffix(".json").exists() or path.with_suffix(".npz").exists()):
        return None, missing
    try:
        model = load(path, settings, key, epoch_stage)
    except (OSError, ValueError, KeyError, TypeError, json.JSONDecodeError) as exc:
        return None, f"rebuilt: {type(exc).__name__}: {exc}"
    model.info["cache"] = found
    return model, found


def ship(models: list[Pretrained], folder: Path = SHIPPED_DIR) -> list[Path]:
    """Make ``models`` the shipped networks: write them, remove every other shipped file.

    Returns the paths written (without suffix).
    """
    folder.mkdir(parents=True, exist_ok=True)
    keep = [folder / f"{PREFIX}{m.info['key']}" for m in models]
    for path, model in zip(keep, models, strict=True):
        save(path, model)
    names = {p.name for stem in keep for p in (stem.with_suffix(".npz"), stem.with_suffix(".json"))}
    for old in folder.glob(f"{PREFIX}*"):
        if old.name not in names:
            old.unlink()
    return keep
