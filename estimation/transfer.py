"""Transfer from virtual subjects: networks pretrained on a population, fine-tuned on a person.

``TransferMLP`` (``"transfer_mlp"``) is an ensemble of small multilayer perceptrons. Each is
pretrained once on the calibration sessions of many virtual subjects (a *corpus*) and then,
for every person, fine-tuned for a few epochs on that person's identification half; the
estimate is the ensemble mean. It needs sEMG only at run time (``free_run``), like the other
deployable estimators, and it never sees the person's validation half.

Why this and not a network trained from scratch: one calibration session holds a few
hundred windows, too few to learn a nonlinear map of 72 inputs; a population of virtual
subjects shows the network how sEMG features relate to grip force across many forearms,
electrode placements and sessions, and fine-tuning adapts that to the person. The logistic
hidden units saturate, so an sEMG excursion outside the calibration range (a loose
electrode, a noisier rest) moves the estimate less than it moves a linear model.

Inputs (normalized features, min-max on the identification data as for every estimator):
``r(k) = [u(k), u(k-1), ..., u(k-lags)]`` (the first window repeated before the start).

Everything that is not fitted per person is chosen on virtual subjects, never on the
person: the corpus (``pretrain_subjects`` subjects of population ``pretrain_seed``), and the
fine-tuning length and step size, chosen on ``VALIDATION_SUBJECTS`` other virtual subjects
(population ``pretrain_seed + 1``) by the mean of their validation R^2 and their worst
subject's. The pretrained weights and that choice are stored as arrays and JSON, keyed by
the settings, the corpus and the source of the modules that make the corpus: the default
ensembles ship in the package (``make pretrained`` writes them), and every ensemble built
is cached (``$GRIPLOOP_CACHE_DIR/pretrained``); a missing, unreadable or mismatched file
is rebuilt, never trusted (:mod:`estimation.pretrained_store`); a cache directory that
cannot be written is a warning (:func:`sim.cache.cached`). Pretraining is deterministic for
a seed (one BLAS thread, seeded networks).

Corpora are registered by name (:mod:`estimation.corpora`) by the layer that records them;
``"virtual"`` is the paper's protocol recorded from virtual subjects with the noise
generator, registered by the scenarios package.
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from estimation import pretrained_store as store
from estimation.base import ForceEstimator
from estimation.baselines.mlp import MLPForward, fit_quietly
from estimation.corpora import Corpus, corpus_builder, corpus_packages, corpus_source
from estimation.deployable import check_period
from estimation.errors import EstimationInputError, check_features, check_mode, check_target
from estimation.metrics import r2_score
from estimation.normalize import MinMaxScaling
from estimation.pretrained_store import Network, Pretrained
from estimation.streaming import scaled
from sim import cache as sim_cache

#: Version of the cache format (weights NPZ + JSON); another version is rebuilt.
FORMAT = 1
#: Population seed of the default corpus: far from the seeds people evaluate with.
PRETRAIN_SEED = 7_000_003
#: Virtual subjects that choose the fine-tuning settings (population ``pretrain_seed + 1``).
VALIDATION_SUBJECTS = 12
#: Candidate fine-tuning step sizes and epochs (in stages of ``EPOCH_STAGE``).
FINETUNE_RATES = (3e-4, 1e-3)
#: Epochs per fine-tuning stage (``warm_start``).
EPOCH_STAGE = 5
MAX_FINETUNE_EPOCHS = 30
#: Population variant of ``transfer_mlp``'s corpus: the one it was measured on real people with.
TRANSFER_POPULATION = "default"
#: Pretraining mini-batch and Adam step size (about 20 s for 3 networks on 40 subjects).
PRETRAIN_BATCH = 128
PRETRAIN_RATE = 2e-3

def lagged(U: np.ndarray, lags: int) -> np.ndarray:
    """``[u(k), u(k-1), ..., u(k-lags)]`` per row, the first row repeated before the start.

    Parameters
    ----------
    U : ndarray, shape (n_samples, n_inputs)
    lags : int

    Returns
    -------
    ndarray, shape (n_samples, n_inputs (lags + 1))
    """
    n = U.shape[0]
    P = np.vstack([np.repeat(U[:1], lags, axis=0), U])
    return np.hstack([P[lags - j: lags - j + n] for j in range(lags + 1)])


# ----------------------------------------------------------------------- networks
def _regressor(hidden: Sequence[int], seed: int, **options: Any) -> Any:
    from sklearn.neural_network import MLPRegressor

    settings = {"hidden_layer_sizes": tuple(hidden), "activation": "logistic", "solver": "adam",
                "learning_rate_init": 1e-3, "batch_size": 64, "alpha": 1e-4, "tol": 0.0,
                "early_stopping": False, "shuffle": True, "random_state": int(seed)}
    settings.update(options)
    settings.setdefault("n_iter_no_change", int(settings.get("max_iter", 200)) + 1)
    return MLPRegressor(**settings)


def _as_network(net: Any) -> Network:
    return Network(tuple(np.array(W) for W in net.coefs_),
                   tuple(np.array(b) for b in net.intercepts_))


def finetune(network: Network, X: np.ndarray, y: np.ndarray, *, epochs: int,
             learning_rate: float, seed: int, hidden: Sequence[int],
             stages: Callable[[Network, int], None] | None = None) -> Network:
    """Continue training ``network`` on ``(X, y)`` for ``epochs`` epochs (in stages of 5).

    scikit-learn's ``MLPRegressor`` is initialized on two rows, given the pretrained
    weights and trained with ``warm_start`` in stages of :data:`EPOCH_STAGE` epochs
    (each stage restarts Adam's moments), shuffling with ``seed``.

    Parameters
    ----------
    network : Network
        Pretrained weights (not modified).
    X : ndarray, shape (n_samples, n_in)
    y : ndarray, shape (n_samples,)
    epochs : int
        A multiple of :data:`EPOCH_STAGE` (0 returns ``network``).
    learning_rate : float
        Adam's step size.
    seed : int
        Shuffling seed.
    hidden : sequence of int
        Hidden layer sizes of ``network``.
    stages : callable, optional
        Called as ``stages(weights, epochs_so_far)`` after every stage (the selection of
        the fine-tuning length scores each stage).
    """
    if epochs <= 0:
        return network
    net = _regressor(hidden, seed, learning_rate_init=learning_rate, batch_size=32,
                     max_iter=EPOCH_STAGE)
    fit_quietly(net.set_params(max_iter=1, batch_size=2), X[:2], y[:2])  # allocate only
    net.coefs_ = [W.copy() for W in network.coefs]
    net.intercepts_ = [b.copy() for b in network.intercepts]
    net.set_params(warm_start=True, max_iter=EPOCH_STAGE, n_iter_no_change=EPOCH_STAGE + 1,
                   batch_size=min(32, X.shape[0]))
    done = 0
    while done < epochs:
        fit_quietly(net, X, y)
        done += EPOCH_STAGE
        if stages is not None:
            stages(_as_network(net), done)
    return _as_network(net)


# ----------------------------------------------------------------------- pretraining
def _choose_finetuning(networks: Sequence[Network], validation: Corpus, lags: int,
                       hidden: Sequence[int]) -> tuple[int, float, dict]:
    """Fine-tuning epochs and step size that serve the validation subjects best.

    Score of a candidate: the mean of the subjects' validation R^2 and of the worst one.
    """
    preds: dict[tuple[float, int], list[list[np.ndarray]]] = {}
    for X_raw, y, n_id in validation:
        X = lagged(X_raw, lags)
        for lr in FINETUNE_RATES:
            X_val = X[n_id:]
            per_epochs: dict[int, list[np.ndarray]] = {0: [n.predict(X_val) for n in networks]}
            for k, net in enumerate(networks):
                def keep(w: Network, done: int, store: dict = per_epochs,
                         rows: np.ndarray = X_val) -> None:
                    store.setdefault(done, []).append(w.predict(rows))
                finetune(net, X[:n_id], y[:n_id], epochs=MAX_FINETUNE_EPOCHS,
                         learning_rate=lr, seed=1000 + k, hidden=hidden, stages=keep)
            for epochs, p in per_epochs.items():
                preds.setdefault((lr, epochs), []).append(np.mean(p, axis=0))
    scores = {}
    for (lr, epochs), p in preds.items():
        r2 = [r2_score(y[n_id:], yh) for (_, y, n_id), yh in zip(validation, p, strict=True)]
        scores[(lr, epochs)] = (float(np.mean(r2)), float(np.min(r2)))
    best = max(scores, key=lambda c: (0.5 * (scores[c][0] + scores[c][1]), -c[1]))
    table = [{"learning_rate": lr, "epochs": e, "r2_mean": m, "r2_min": w}
             for (lr, e), (m, w) in sorted(scores.items())]
    return best[1], best[0], {"candidates": table}


_SOURCE_PACKAGES = ("sim.recording", "estimation")


@functools.cache
def source_digest(corpus: str) -> str:
    """SHA-256 of everything that makes ``corpus``'s pretrained networks, and the version.

    Every module of the packages the corpus depends on
    (:func:`estimation.corpora.corpus_packages`: the virtual subjects for ``"virtual"``),
    of :mod:`sim.recording` (the recording type) and of :mod:`estimation` (features,
    scaling, this module, and the subpackages: ``baselines/mlp.py`` trains the networks),
    walked as the design cache walks its packages (:func:`sim.cache.source_digest`), and
    the module of the corpus's builder (:func:`estimation.corpora.corpus_source`): an edit
    to any of them makes the cached and the shipped networks stale.

    Raises
    ------
    estimation.corpora.UnknownCorpusError
        ``corpus`` is not registered.
    """
    packages = (*corpus_packages(corpus), *_SOURCE_PACKAGES)
    h = hashlib.sha256(sim_cache.source_digest(packages).encode())
    h.update(corpus_source(corpus))
    return h.hexdigest()


_MEMO: dict[str, Pretrained] = {}


@dataclass(frozen=True)
class Pretraining:
    """What a pretrained ensemble is made from: its corpus, its networks, their training.

    Attributes
    ----------
    corpus : str
        Registered pretraining corpus (:func:`estimation.corpora.register_corpus`).
    n_subjects : int
        Virtual subjects in the corpus.
    seed : int
        Population seed of the corpus (validation subjects: population ``seed + 1``).
    hidden : tuple of int
        Hidden layer sizes (logistic units).
    lags : int
        Past windows in the input.
    n_networks : int
        Networks in the ensemble (each pretrained with its own seed).
    epochs : int
        Epochs of pretraining.
    validation_subjects : int
        Virtual subjects on which the fine-tuning length and step size are chosen.
    population : str
        Population variant of the corpus (``sim.user.populations``).
    """

    corpus: str = "virtual"
    n_subjects: int = 40
    seed: int = PRETRAIN_SEED
    hidden: tuple[int, ...] = (32, 16)
    lags: int = 2
    n_networks: int = 3
    epochs: int = 60
    validation_subjects: int = VALIDATION_SUBJECTS
    population: str = "default"

    def settings(self, n_inputs: int) -> dict:
        """The ensemble's settings for ``n_inputs`` features, as stored and keyed (JSON).

        Raises
        ------
        estimation.corpora.UnknownCorpusError
            The corpus is not registered.
        """
        return {"format": FORMAT, "n_inputs": int(n_inputs), "corpus": self.corpus,
                "population": str(self.population),
                "pretrain_subjects": int(self.n_subjects), "pretrain_seed": int(self.seed),
                "hidden": [int(h) for h in self.hidden], "lags": int(self.lags),
                "n_networks": int(self.n_networks), "pretrain_epochs": int(self.epochs),
                "pretrain_batch": PRETRAIN_BATCH, "pretrain_rate": PRETRAIN_RATE,
                "validation_subjects": int(self.validation_subjects),
                "source": source_digest(self.corpus)}


def _key(settings: dict) -> str:
    return hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:24]


def build_pretrained(settings: dict) -> Pretrained:
    """Pretrain the networks of ``settings`` and choose their fine-tuning (no cache)."""
    import time

    from estimation.threads import one_blas_thread

    t0 = time.perf_counter()
    builder = corpus_builder(settings["corpus"])
    lags, hidden = settings["lags"], settings["hidden"]
    with one_blas_thread():
        train = builder(n_inputs=settings["n_inputs"], n_subjects=settings["pretrain_subjects"],
                        seed=settings["pretrain_seed"], population=settings["population"])
        validation = builder(n_inputs=settings["n_inputs"],
                             n_subjects=settings["validation_subjects"],
                             seed=settings["pretrain_seed"] + 1,
                             population=settings["population"])
        X = np.vstack([lagged(U, lags) for U, _, _ in train])
        y = np.concatenate([t for _, t, _ in train])
        networks = []
        for k in range(settings["n_networks"]):
            net = _regressor(hidden, settings["pretrain_seed"] + k,
                             max_iter=settings["pretrain_epochs"], batch_size=PRETRAIN_BATCH,
                             learning_rate_init=PRETRAIN_RATE)
            fit_quietly(net, X, y)
            networks.append(_as_network(net))
        epochs, lr, scores = _choose_finetuning(networks, validation, lags, hidden)
    info = dict(settings, key=_key(settings), n_windows=int(X.shape[0]),
                build_s=time.perf_counter() - t0, finetune=scores)
    return Pretrained(tuple(networks), epochs, lr, info)


def pretrained(n_inputs: int, pretraining: Pretraining | None = None) -> Pretrained:
    """The pretrained ensemble for ``n_inputs`` features: memory, shipped, disk, else built.

    A stored file (shipped in the package, or in the cache) is used only if its JSON
    states exactly these settings and this source digest and its arrays have the expected
    shapes and finite values; anything else (missing, corrupt, another version) is rebuilt
    and written to the cache (:mod:`estimation.pretrained_store`). ``info["cache"]`` says
    which happened (``"memory"``, ``"shipped"``, ``"disk"``, ``"built"``, ``"rebuilt:
    <reason>"``).

    Parameters
    ----------
    n_inputs : int
        Features per window.
    pretraining : Pretraining, optional
        What the ensemble is made from (default: ``Pretraining()``, the shipped one).
    """
    settings = (pretraining or Pretraining()).settings(n_inputs)
    key = _key(settings)
    if key not in _MEMO:
        model, status = store.read(store.SHIPPED_DIR / f"{store.PREFIX}{key}", settings, key,
                                   EPOCH_STAGE, found="shipped")
        _MEMO[key] = model if model is not None else _from_cache(settings, key, status)
    return _MEMO[key]


def _from_cache(settings: dict, key: str, missing: str) -> Pretrained:
    """The ensemble from the disk cache, or built and stored (:func:`sim.cache.cached`).

    ``info["cache"]`` of a built one says why the stored files were not used (``missing``
    when there were none).
    """
    folder = sim_cache.cache_subdir("pretrained")
    path = None if folder is None else folder / f"{store.PREFIX}{key}"
    why = missing  # the last read's reason, for a model built after it

    def read(path: Path) -> Pretrained | None:
        nonlocal why
        model, why = store.read(path, settings, key, EPOCH_STAGE, found="disk", missing=why)
        return model

    def build() -> Pretrained:
        model = build_pretrained(settings)
        model.info["cache"] = why
        return model

    model, _ = sim_cache.cached(path, read, build, store.save)
    return model


def pretrained_for(estimator: Any, n_inputs: int, hidden: Sequence[int]) -> Pretrained:
    """The ensemble an estimator's pretraining settings name (:func:`pretrained`).

    ``estimator`` carries ``corpus``, ``pretrain_subjects``, ``pretrain_seed``, ``lags``,
    ``n_networks``, ``pretrain_epochs``, ``validation_subjects`` and ``population``
    (:class:`TransferMLP`, :class:`estimation.adaptive.AdaptiveMLP`); ``hidden`` are the
    pretrained networks' layer sizes.
    """
    return pretrained(n_inputs, Pretraining(
        corpus=estimator.corpus, n_subjects=estimator.pretrain_subjects,
        seed=estimator.pretrain_seed, hidden=tuple(hidden), lags=estimator.lags,
        n_networks=estimator.n_networks, epochs=estimator.pretrain_epochs,
        validation_subjects=estimator.validation_subjects, population=estimator.population))


#: Feature layouts whose default ensembles ship: all 8 channels and channels 6-8 (MAV, RMS
#: and WL of each; ``scenarios.runners.pretraining.LAYOUTS``).
SHIPPED_LAYOUTS = (24, 9)
#: Population variants whose default ensembles ship: ``transfer_mlp``'s, which
#: ``adaptive_mlp`` adapts too (:data:`estimation.adaptive.ADAPT_POPULATION`).
SHIPPED_POPULATIONS = (TRANSFER_POPULATION,)


def ship_default_networks(n_inputs: Sequence[int] = SHIPPED_LAYOUTS,
                          populations: Sequence[str] = SHIPPED_POPULATIONS) -> list[Path]:
    """Write the default ensembles (all 8 channels and channels 6-8, of each population).

    ``make pretrained`` runs this after a change to what builds them (the key's source
    digest); each is read from the cache or built first. Returns the stems written.
    """
    return store.ship([pretrained(n, Pretraining(population=p))
                       for p in populations for n in n_inputs])


def clear_memory() -> None:
    """Forget the pretrained ensembles held in this process (the disk cache stays)."""
    _MEMO.clear()


# ----------------------------------------------------------------------- estimator
class TransferMLP(ForceEstimator):
    """Ensemble of MLPs pretrained on virtual subjects and fine-tuned on the person.

    Parameters
    ----------
    n_networks : int
        Networks in the ensemble (each pretrained with its own seed).
    hidden : tuple of int
        Hidden layer sizes (logistic units).
    lags : int
        Past windows in the input.
    corpus : str
        Registered pretraining corpus (:func:`estimation.corpora.register_corpus`).
    pretrain_subjects : int
        Virtual subjects in the corpus.
    pretrain_seed : int
        Population seed of the corpus (validation subjects: ``pretrain_seed + 1``).
    pretrain_epochs : int
        Epochs of pretraining.
    validation_subjects : int
        Virtual subjects (population ``pretrain_seed + 1``) on which the fine-tuning
        length and step size are chosen.
    population : str
        The population variant of the corpus (``sim.user.populations``; the default one
        is what these networks were pretrained on when they were measured on real
        recordings: free_run 0.808, worst 0.48, shared/REAL_RECORDINGS.md).
    dt_s : float
        Window increment in seconds; streams refuse a shorter ``period_s``.
    random_state : numpy.random.Generator, int or None
        Seeds the fine-tuning's shuffling.

    Attributes
    ----------
    networks_ : tuple of Network
        The fine-tuned networks.
    finetune_epochs_, finetune_learning_rate_ : int, float
        Fine-tuning settings (chosen on virtual validation subjects at pretraining).
    pretrained_info_ : dict
        Pretraining settings, cache status and validation scores.
    """

    modes = ("one_step", "free_run")  # the force is never used: both modes coincide

    def __init__(self, *, n_networks: int = 3, hidden: tuple[int, ...] = (32, 16),
                 lags: int = 2, corpus: str = "virtual", pretrain_subjects: int = 40,
                 pretrain_seed: int = PRETRAIN_SEED, pretrain_epochs: int = 60,
                 validation_subjects: int = VALIDATION_SUBJECTS,
                 population: str = TRANSFER_POPULATION, dt_s: float = 0.125,
                 random_state: np.random.Generator | int | None = None) -> None:
        self.n_networks = n_networks
        self.hidden = hidden
        self.lags = lags
        self.corpus = corpus
        self.pretrain_subjects = pretrain_subjects
        self.pretrain_seed = pretrain_seed
        self.pretrain_epochs = pretrain_epochs
        self.validation_subjects = validation_subjects
        self.population = population
        self.dt_s = dt_s
        self.random_state = random_state

    def _check_settings(self) -> None:
        ints = {"n_networks": self.n_networks, "lags": self.lags,
                "pretrain_subjects": self.pretrain_subjects,
                "pretrain_epochs": self.pretrain_epochs,
                "validation_subjects": self.validation_subjects}
        bad = {k: v for k, v in ints.items() if int(v) != v or v < (0 if k == "lags" else 1)}
        if bad or not self.hidden or min(self.hidden) < 1:
            raise EstimationInputError(
                f"TransferMLP: expected positive counts and hidden sizes, found {bad or ''} "
                f"hidden={self.hidden!r}")

    def fit(self, U: np.ndarray, y: np.ndarray) -> TransferMLP:
        """Fine-tune the pretrained ensemble on normalized features ``U`` and force ``y``.

        Parameters
        ----------
        U : ndarray, shape (n_samples, n_inputs)
            Normalized features of the person's identification data.
        y : ndarray, shape (n_samples,)
            Normalized force.

        Raises
        ------
        EstimationInputError
            Fewer than 8 windows, bad settings, or a feature layout the corpus cannot make.
        """
        U = check_features(U, who="TransferMLP", min_samples=8)
        y = check_target(y, U.shape[0])
        self._check_settings()
        model = pretrained_for(self, U.shape[1], self.hidden)
        seeds = np.random.default_rng(self.random_state).integers(0, 2**31 - 1, self.n_networks)
        X = lagged(U, self.lags)
        self.networks_ = tuple(
            finetune(net, X, y, epochs=model.epochs, learning_rate=model.learning_rate,
                     seed=int(s), hidden=tuple(self.hidden))
            for net, s in zip(model.networks, seeds, strict=True))
        self.finetune_epochs_ = model.epochs
        self.finetune_learning_rate_ = model.learning_rate
        self.pretrained_info_ = {k: v for k, v in model.info.items() if k != "finetune"}
        self.n_features_in_ = U.shape[1]
        return self

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """Force estimate (normalized), shape (n_samples,); ``y`` is ignored (sEMG only)."""
        self._mode(mode, y)
        U = check_features(U, n_inputs=self.n_features_in_, who="TransferMLP")
        X = lagged(U, self.lags)
        return np.mean([net.predict(X) for net in self.networks_], axis=0)

    def streaming(self, mode: str = "free_run", *, scaling: MinMaxScaling | None = None,
                  period_s: float | None = None) -> object:
        """A stream equal to :meth:`predict`; ``period_s`` (s) shorter than ``dt_s`` is refused."""
        check_mode(mode, self.modes, "TransferMLP")
        check_period(period_s, self.dt_s, "TransferMLP")
        return scaled(TransferStream(self.networks_, self.lags, self.n_features_in_, mode),
                      scaling)


class TransferStream:
    """One window at a time: a ring of the last ``lags + 1`` inputs, then every network.

    Each network runs :class:`estimation.baselines.mlp.MLPForward`; the estimate is their
    mean.

    Parameters
    ----------
    networks : sequence of Network
        The ensemble.
    lags : int
        Past windows in the input.
    n_inputs : int
        Features per window.
    mode : str
        The mode it is streamed in (the force is never used).
    """

    uses_force = False

    def __init__(self, networks: Sequence[Network], lags: int, n_inputs: int, mode: str) -> None:
        self.mode = mode
        self._lags = lags
        self._n = n_inputs
        self._x = np.empty(n_inputs * (lags + 1))
        self._forwards = [MLPForward(net) for net in networks]
        self._started = False

    def reset(self) -> None:
        """Forget the past windows."""
        self._started = False

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Force estimate (normalized) for the newest window's features ``u`` (n_inputs,)."""
        n, x = self._n, self._x
        if not self._started:
            for j in range(self._lags + 1):
                x[j * n:(j + 1) * n] = u
            self._started = True
        else:
            x[n:] = x[:-n].copy() if self._lags else x[n:]
            x[:n] = u
        total = 0.0
        for forward in self._forwards:
            total += forward(x)
        return total / len(self._forwards)
