"""Compile the closed loop's numba code once per test process, before any test:
the first compiled call otherwise lands inside a test and can exceed a hypothesis
deadline (numba's start-up is about 1 s with the on-disk cache, 10 s without)."""

from __future__ import annotations

import pytest

from cosim.control.warm import warm_up


@pytest.fixture(scope="session", autouse=True)
def _compiled_closed_loop() -> None:
    warm_up()
