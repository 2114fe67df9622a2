"""Estimation tests: the ``"virtual"`` pretraining corpus is registered, as every command has it.

``transfer_mlp`` and ``adaptive_mlp`` pretrain on the ``"virtual"`` corpus by default; the
scenarios package registers it when imported (estimation names no module above it), so the
tests that fit them with their defaults import it here, as the ``griploop`` commands do.
"""

import scenarios  # noqa: F401  (registers the "virtual" corpus of estimation.corpora)
