"""Shared recordings and the compiler check of the C export tests."""

from __future__ import annotations

import os

import numpy as np
import pytest

from scenarios.deploy.build import CompilerMissingError, host_compiler
from scenarios.runners.subject import calibration_session
from sim.user.subjects import VirtualSubject


def need(check, what: str) -> None:
    """Skip with the one line that says what to install; under CI (CI=true) fail instead."""
    try:
        check()
    except CompilerMissingError as exc:  # also the target's TargetToolsMissingError
        message = f"{what}: {exc}"
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(message)
        pytest.skip(message)


@pytest.fixture(scope="session")
def c_compiler() -> str:
    """The host C compiler (the tests that compile skip, in one line, without one)."""
    need(host_compiler, "C export tests need a C compiler")
    return host_compiler()


@pytest.fixture(scope="session")
def arm_tools() -> None:
    """The cross compiler and QEMU (the target tests skip, in one line, without them)."""
    from scenarios.deploy.target import target_tools

    need(target_tools, "the Cortex-M4 target tests need the cross compiler and QEMU")


@pytest.fixture(scope="session")
def sessions():
    """Two calibration sessions of one virtual subject: one to fit on, one to replay."""
    subject = VirtualSubject.sample(0, 1)
    fit, _ = calibration_session(subject, np.random.default_rng(0))
    replay, _ = calibration_session(subject, np.random.default_rng(1))
    return fit, replay
