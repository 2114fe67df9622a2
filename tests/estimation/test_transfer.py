"""Pretrained-then-fine-tuned MLP ensemble: contract, stream, determinism and its cache."""

from __future__ import annotations

import json

import numpy as np
import pytest
from est_synthetic import SMALL_TRANSFER, register_synthetic_corpus, synthetic_corpus

from estimation import transfer
from estimation.corpora import UnknownCorpusError
from estimation.errors import EstimationInputError, InsufficientDataError
from estimation.transfer import (
    EPOCH_STAGE,
    Pretraining,
    TransferMLP,
    clear_memory,
    lagged,
    pretrained,
)

N_INPUTS = 6


def _session(rng, n=240):
    """One synthetic subject of :func:`est_synthetic.synthetic_corpus`."""
    return synthetic_corpus(n_inputs=N_INPUTS, n_subjects=1, seed=int(rng.integers(1 << 30)),
                            n_windows=n)[0]


register_synthetic_corpus()
SMALL = dict(SMALL_TRANSFER, pretrain_subjects=6, pretrain_epochs=10, validation_subjects=3)


@pytest.fixture(autouse=True)
def _fresh_memory():
    clear_memory()
    yield
    clear_memory()


def test_lagged_repeats_the_first_row_before_the_start():
    U = np.arange(6.0).reshape(3, 2)
    np.testing.assert_array_equal(lagged(U, 1), [[0, 1, 0, 1], [2, 3, 0, 1], [4, 5, 2, 3]])
    np.testing.assert_array_equal(lagged(U, 0), U)


def test_fit_predict_and_stream_agree_and_track_the_force():
    U, y, n_id = _session(np.random.default_rng(99))
    est = TransferMLP(**SMALL, random_state=0).fit(U[:n_id], y[:n_id])
    batch = est.predict(U)
    stream = est.streaming("free_run")
    stream.reset()
    streamed = np.array([stream.step(u) for u in U])
    np.testing.assert_allclose(streamed, batch, atol=1e-12)
    assert np.corrcoef(batch[n_id:], y[n_id:])[0, 1] > 0.8
    assert est.finetune_epochs_ % EPOCH_STAGE == 0 and est.finetune_learning_rate_ > 0
    assert len(est.networks_) == 2 and est.pretrained_info_["pretrain_subjects"] == 6


def test_same_seed_same_numbers_and_pretraining_is_deterministic(tmp_path, monkeypatch):
    U, y, n_id = _session(np.random.default_rng(5))
    a = TransferMLP(**SMALL, random_state=3).fit(U[:n_id], y[:n_id]).predict(U)
    b = TransferMLP(**SMALL, random_state=3).fit(U[:n_id], y[:n_id]).predict(U)
    np.testing.assert_array_equal(a, b)
    small = Pretraining(corpus="synthetic-test", n_subjects=6, epochs=10, hidden=(8,),
                        n_networks=2, validation_subjects=3)
    first = pretrained(N_INPUTS, small)
    clear_memory()
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(tmp_path))  # nothing cached there: rebuilt
    second = pretrained(N_INPUTS, small)
    assert second.info["cache"] == "built"
    for n1, n2 in zip(first.networks, second.networks, strict=True):
        for w1, w2 in zip(n1.coefs, n2.coefs, strict=True):
            np.testing.assert_array_equal(w1, w2)


def test_cache_is_read_back_and_a_corrupt_or_foreign_file_is_rebuilt(tmp_path, monkeypatch):
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(tmp_path))
    kw = {"corpus": "synthetic-test", "n_subjects": 6, "epochs": 10, "hidden": (8,),
          "n_networks": 2, "validation_subjects": 3}
    built = pretrained(N_INPUTS, Pretraining(**kw))
    assert built.info["cache"] == "built"
    assert pretrained(N_INPUTS, Pretraining(**kw)) is built  # memory
    clear_memory()
    read = pretrained(N_INPUTS, Pretraining(**kw))
    assert read.info["cache"] == "disk" and read.epochs == built.epochs
    np.testing.assert_array_equal(read.networks[1].coefs[0], built.networks[1].coefs[0])
    files = sorted((tmp_path / "pretrained").iterdir())
    npz = next(f for f in files if f.suffix == ".npz")
    meta = next(f for f in files if f.suffix == ".json")
    # a corrupt array file
    npz.write_bytes(b"not an npz")
    clear_memory()
    rebuilt = pretrained(N_INPUTS, Pretraining(**kw))
    assert rebuilt.info["cache"].startswith("rebuilt")
    np.testing.assert_array_equal(rebuilt.networks[0].coefs[0], built.networks[0].coefs[0])
    # a file from another format version
    data = json.loads(meta.read_text())
    meta.write_text(json.dumps(dict(data, format=data["format"] + 1)))
    clear_memory()
    assert pretrained(N_INPUTS, Pretraining(**kw)).info["cache"].startswith("rebuilt: ValueError")
    # weights with the wrong shape
    clear_memory()
    with np.load(npz) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["net0_W0"] = arrays["net0_W0"][:, :3]
    np.savez(npz, **arrays)
    assert pretrained(N_INPUTS, Pretraining(**kw)).info["cache"].startswith("rebuilt: ValueError")


def _pretrain_in_child(kw: dict, queue) -> None:
    queue.put(pretrained(N_INPUTS, Pretraining(**kw)).info["cache"])


def test_processes_wanting_the_same_network_build_it_once(tmp_path, monkeypatch):
    # parallel test workers and sweep workers share one cache: the first builds, the
    # others wait for it and read its file
    import multiprocessing

    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(tmp_path))
    kw = {"corpus": "synthetic-test", "n_subjects": 6, "epochs": 10, "hidden": (8,),
          "n_networks": 2, "validation_subjects": 3}
    ctx = multiprocessing.get_context("fork")  # the children keep the registered corpus
    queue = ctx.Queue()
    children = [ctx.Process(target=_pretrain_in_child, args=(kw, queue)) for _ in range(3)]
    for child in children:
        child.start()
    statuses = sorted(queue.get(timeout=120) for _ in children)
    for child in children:
        child.join(10)
    assert statuses == ["built", "disk", "disk"]
    assert len(list((tmp_path / "pretrained").glob("*.npz"))) == 1


def test_cache_can_be_switched_off(monkeypatch):
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", "off")
    model = pretrained(N_INPUTS, Pretraining(corpus="synthetic-test", n_subjects=4, epochs=5,
                                             hidden=(4,), n_networks=1, validation_subjects=2))
    assert model.info["cache"] == "built"


def test_an_unwritable_cache_warns_once_and_the_networks_are_still_built(tmp_path,
                                                                         monkeypatch):
    import warnings

    from sim.cache import CacheNotWritableWarning

    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(blocker))  # its "pretrained" cannot be made
    small = Pretraining(corpus="synthetic-test", n_subjects=4, epochs=5, hidden=(4,),
                        n_networks=1, validation_subjects=2)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(2):
            clear_memory()
            model = pretrained(N_INPUTS, small)
            assert model.info["cache"] == "built" and len(model.networks) == 1
    said = [w for w in caught if issubclass(w.category, CacheNotWritableWarning)]
    assert len(said) == 1 and "pretrained" in str(said[0].message)


def test_bad_input_is_named():
    U, y, n_id = _session(np.random.default_rng(1))
    with pytest.raises(EstimationInputError, match="24 inputs.*9 inputs.*found 6 inputs"):
        TransferMLP(random_state=0).fit(U[:n_id], y[:n_id])  # the virtual corpus: 24 or 9
    with pytest.raises(InsufficientDataError, match="at least 8 samples"):
        TransferMLP(**SMALL).fit(U[:5], y[:5])
    with pytest.raises(UnknownCorpusError, match="no-such-corpus"):
        TransferMLP(**dict(SMALL, corpus="no-such-corpus")).fit(U[:n_id], y[:n_id])
    with pytest.raises(EstimationInputError, match="positive counts"):
        TransferMLP(**dict(SMALL, n_networks=0)).fit(U[:n_id], y[:n_id])
    est = TransferMLP(**SMALL, random_state=0).fit(U[:n_id], y[:n_id])
    with pytest.raises(EstimationInputError):
        est.predict(U[:, :3])


def test_the_shipped_networks_are_those_this_code_builds(tmp_path, monkeypatch):
    """``make pretrained`` wrote the default ensembles of this source (its digest is in the key).

    If this fails, what builds them changed: run ``make pretrained`` and commit the files.
    """
    from estimation import pretrained_store as store

    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(tmp_path))  # an empty cache
    monkeypatch.setattr(transfer, "build_pretrained", lambda settings: pytest.fail(
        f"no shipped networks for {settings['n_inputs']} inputs of this source: run "
        "`make pretrained`"))
    # the defaults, as TransferMLP and AdaptiveMLP ask for them
    from estimation.adaptive import ADAPT_POPULATION

    assert set(transfer.SHIPPED_POPULATIONS) == {transfer.TRANSFER_POPULATION, ADAPT_POPULATION}
    for population in transfer.SHIPPED_POPULATIONS:
        for n_inputs in transfer.SHIPPED_LAYOUTS:
            model = pretrained(n_inputs, Pretraining(population=population))
            assert model.info["cache"] == "shipped" and len(model.networks) == 3
            assert model.epochs % EPOCH_STAGE == 0
    assert not (tmp_path / "pretrained").exists()  # nothing copied into the cache
    assert len(list(store.SHIPPED_DIR.glob("*.npz"))) == (
        len(transfer.SHIPPED_LAYOUTS) * len(transfer.SHIPPED_POPULATIONS))


def test_shipped_networks_are_trusted_only_for_their_own_settings(tmp_path, monkeypatch):
    from estimation import pretrained_store as store

    kw = {"corpus": "synthetic-test", "n_subjects": 6, "epochs": 10, "hidden": (8,),
          "n_networks": 2, "validation_subjects": 3}
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(tmp_path / "cache"))
    built = pretrained(N_INPUTS, Pretraining(**kw))
    shipped = tmp_path / "shipped"
    shipped.mkdir()
    (shipped / f"{store.PREFIX}stale.npz").write_bytes(b"old")
    monkeypatch.setattr(store, "SHIPPED_DIR", shipped)
    (stem,) = store.ship([built], shipped)
    assert sorted(p.name for p in shipped.iterdir()) == [stem.name + ".json",
                                                         stem.name + ".npz"]  # stale removed
    clear_memory()
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(tmp_path / "empty"))
    read = pretrained(N_INPUTS, Pretraining(**kw))
    assert read.info["cache"] == "shipped" and read.epochs == built.epochs
    np.testing.assert_array_equal(read.networks[1].coefs[0], built.networks[1].coefs[0])
    assert pretrained(N_INPUTS, Pretraining(**dict(kw, epochs=5))).info["cache"] == "built"
    meta = stem.with_suffix(".json")
    meta.write_text(json.dumps(dict(json.loads(meta.read_text()), n_networks=3)))
    clear_memory()
    again = pretrained(N_INPUTS, Pretraining(**kw))  # the mismatched shipped file is not used
    assert again.info["cache"].startswith("rebuilt: ValueError: settings differ")
    np.testing.assert_array_equal(again.networks[0].coefs[0], built.networks[0].coefs[0])


def test_the_source_digest_walks_every_package_that_makes_the_networks(monkeypatch):
    from sim import cache as sim_cache

    asked = []
    real = sim_cache.source_digest
    monkeypatch.setattr(sim_cache, "source_digest",
                        lambda packages, *a, **kw: asked.extend(packages) or real(packages))
    transfer.source_digest.cache_clear()
    try:
        transfer.source_digest("virtual")  # registered by scenarios (conftest.py)
    finally:
        transfer.source_digest.cache_clear()
    # the virtual subjects, the recording type, the features and the trainer
    # (estimation/baselines/mlp.py, found by the walk of estimation's subpackages)
    assert {"sim.user", "sim.recording", "estimation"} <= set(asked)
