"""The scratch MLP averaged with the adapted pretrained ensemble: contract, fallback, stream."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from est_synthetic import register_synthetic_corpus, synthetic_corpus

from estimation.adaptive import AdaptationWarning, AdaptiveMLP
from estimation.baselines.mlp import MLPBaseline
from estimation.errors import EstimationInputError
from estimation.transfer import Pretraining, clear_memory, pretrained

N_INPUTS = 6
register_synthetic_corpus()
SMALL = {"corpus": "synthetic-test", "pretrain_subjects": 6, "pretrain_epochs": 10,
         "transfer_hidden": (8,), "n_networks": 2, "validation_subjects": 3,
         "finetune_epochs": 10, "max_epochs": 200}


@pytest.fixture(autouse=True)
def _fresh_memory():
    clear_memory()
    yield
    clear_memory()


def _session(seed=7, n=240):
    return synthetic_corpus(n_inputs=N_INPUTS, n_subjects=1, seed=seed, n_windows=n)[0]


def test_fit_predict_and_stream_agree_and_average_the_two_models():
    U, y, n_id = _session()
    est = AdaptiveMLP(**SMALL, random_state=0).fit(U[:n_id], y[:n_id])
    assert len(est.networks_) == 2 and est.weight_ == 0.5
    assert "averaged with 2 pretrained networks fine-tuned 10 epochs" in est.decision_
    batch = est.predict(U)
    scratch = est.scratch_.predict(U)
    assert not np.allclose(batch, scratch)  # the ensemble takes half
    stream = est.streaming("free_run")
    stream.reset()
    streamed = np.array([stream.step(u) for u in U])
    np.testing.assert_allclose(streamed, batch, atol=1e-12)
    assert np.corrcoef(batch[n_id:], y[n_id:])[0, 1] > 0.8
    # the scratch model is the paper's MLP, fitted as the MLP baseline is
    assert isinstance(est.scratch_, MLPBaseline) and est.scratch_.hidden == 4


def test_same_seed_same_numbers():
    U, y, n_id = _session(3)
    a = AdaptiveMLP(**SMALL, random_state=5).fit(U[:n_id], y[:n_id]).predict(U)
    b = AdaptiveMLP(**SMALL, random_state=5).fit(U[:n_id], y[:n_id]).predict(U)
    np.testing.assert_array_equal(a, b)


def test_too_short_an_identification_half_falls_back_to_the_scratch_model_and_says_so():
    U, y, _ = _session(11)
    short = 60  # 7.5 s of windows: too few to trust an adaptation
    with pytest.warns(AdaptationWarning) as caught:
        est = AdaptiveMLP(**SMALL, random_state=0).fit(U[:short], y[:short])
    (message,) = [str(w.message) for w in caught]
    assert "\n" not in message and "60 identification windows are too few" in message
    assert "own MLP alone" in message and est.decision_ == message
    assert est.networks_ == () and est.weight_ == 1.0 and est.pretrained_info_ is None
    np.testing.assert_array_equal(est.predict(U), est.scratch_.predict(U))
    stream = est.streaming()
    stream.reset()
    np.testing.assert_allclose([stream.step(u) for u in U], est.predict(U), atol=1e-12)
    # a long enough half adapts, without a warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", AdaptationWarning)
        AdaptiveMLP(**SMALL, random_state=0).fit(U[:120], y[:120])


def test_bad_settings_and_inputs_are_named():
    U, y, n_id = _session()
    for bad in ({"scratch_weight": 1.5}, {"finetune_epochs": 7}, {"n_networks": 0},
                {"finetune_learning_rate": 0.0}):
        with pytest.raises(EstimationInputError, match="scratch_weight in 0..1"):
            AdaptiveMLP(**dict(SMALL, **bad)).fit(U[:n_id], y[:n_id])
    with pytest.raises(EstimationInputError, match="24 inputs.*9 inputs"):
        AdaptiveMLP(random_state=0).fit(U[:n_id], y[:n_id])  # the virtual corpus: 24 or 9
    est = AdaptiveMLP(**SMALL, random_state=0).fit(U[:n_id], y[:n_id])
    with pytest.raises(EstimationInputError):
        est.predict(U[:, :3])


def test_networks_of_another_population_are_other_networks(tmp_path, monkeypatch):
    # the population variant is part of the pretrained key: a file of another population
    # (or version) is never read for this one
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(tmp_path))
    kw = {"corpus": "synthetic-test", "n_subjects": 4, "epochs": 5, "hidden": (4,),
          "n_networks": 1, "validation_subjects": 2}
    a = pretrained(N_INPUTS, Pretraining(population="default", **kw))
    b = pretrained(N_INPUTS, Pretraining(population="wide", **kw))
    assert a.info["key"] != b.info["key"] and b.info["cache"] == "built"
    assert {p.stem for p in (tmp_path / "pretrained").glob("*.json")} == {
        f"transfer_mlp-{a.info['key']}", f"transfer_mlp-{b.info['key']}"}
