"""Fuzzing an env's actions: arrays of any shape and type, NaN and infinities, nested lists,
text, None. ``step`` must act or raise the env's named error (field ``action``), never numpy's
(:mod:`tests.fuzzing`).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from cell.errors import InputError
from envs import CutEnv
from tests.fuzzing import NASTY_FLOATS, SLOW_EXAMPLES, numbers, values


def actions() -> st.SearchStrategy[Any]:
    """Actions a careless caller passes: arrays of any small shape and dtype, nested lists,
    scalars, text, None."""
    floats = st.one_of(st.floats(), st.sampled_from(NASTY_FLOATS))
    return st.one_of(
        hnp.arrays(np.float64, hnp.array_shapes(min_dims=0, max_dims=3, max_side=4),
                   elements=floats),
        hnp.arrays(st.sampled_from([np.int64, np.float32, np.bool_, np.complex128]),
                   hnp.array_shapes(min_dims=0, max_dims=2, max_side=4)),
        st.lists(st.one_of(numbers(), st.lists(numbers(), max_size=3)), max_size=4),
        values(), st.none(), st.integers(min_value=2**64), st.just([10**400, 0]))


@pytest.fixture(scope="module")
def env() -> Iterator[CutEnv]:
    cell = CutEnv(cell_size_m=0.08, time_limit_s=0.4, randomize=False)
    cell.reset(seed=0)
    yield cell
    cell.close()


def _step(env: CutEnv, action: Any) -> None:
    try:
        *_, terminated, truncated, _ = env.step(action)
    except InputError as error:
        assert error.field == "action", error
        return
    if terminated or truncated:
        env.reset(seed=0)


def _settings(examples: int) -> settings:
    return settings(max_examples=examples, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow])


@_settings(60)
@given(action=actions())
def test_env_actions(env: CutEnv, action: Any) -> None:
    _step(env, action)


@pytest.mark.slow
@_settings(SLOW_EXAMPLES)
@given(action=actions())
def test_env_actions_slow(env: CutEnv, action: Any) -> None:
    _step(env, action)
