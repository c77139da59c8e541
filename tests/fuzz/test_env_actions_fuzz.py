"""Gymnasium actions, seeds and reset options of any shape and value (issue 36), for the single and
the vector env: each is taken (the step's numbers all finite) or refused with a ``ValueError`` of
one line naming it (Gymnasium's own ``gymnasium.error.Error`` for a bad seed of the single env),
never a traceback of another kind, never a warning, never a hang; a refusal changes nothing and the
episode goes on.

Property-based (hypothesis, derandomized like tests/data/test_fuzz.py). Cases: 4 tests x 175
drawn examples = 700, and 7 reproducers; 707 in all.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import mazeslam  # noqa: F401  (registers the environments)

FUZZ = settings(
    max_examples=175,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
ENVS = 3

#: Numbers an action may hold: in and out of the bounds, not finite, beyond any float.
NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, 0.5, -1.0, 1.0, 1e300, np.nan, np.inf, -np.inf]),
    st.integers(-(2**80), 2**80),
    st.sampled_from([10**400, True, None, "0.5", "left", 1 + 2j]),
)


def actions(shape: tuple[int, ...]) -> st.SearchStrategy:
    """Actions near ``shape`` (the space's): numpy arrays of any dtype and of shapes around it,
    nested lists of odd numbers, scalars, strings, dicts."""
    shapes = st.sampled_from([shape, (), (0,), (1,), (shape[-1] + 1,), (*shape, 1), shape[::-1], (2, *shape)])
    dtypes = st.sampled_from([np.float64, np.float32, np.float16, np.int64, np.int8, np.bool_, np.complex128])
    arrays = st.builds(lambda dtype, shape: (dtype, shape), dtypes, shapes).flatmap(
        lambda pair: hnp.arrays(pair[0], pair[1], elements=None if pair[0] is not np.float64 else NUMBERS_F64)
    )
    nested = st.lists(st.lists(NUMBERS, min_size=1, max_size=3), min_size=1, max_size=ENVS + 1)
    flat = st.lists(NUMBERS, min_size=0, max_size=4)
    return st.one_of(arrays, nested, flat, NUMBERS, st.dictionaries(st.text(max_size=3), NUMBERS, max_size=2))


NUMBERS_F64 = st.floats(allow_nan=True, allow_infinity=True, width=64)


def one_line_refusal(error: BaseException) -> None:
    message = str(error)
    assert message and "\n" not in message, repr(message)


@pytest.fixture(scope="module")
def single():
    return gym.make("mazeslam/Maze-v0", rows=3, cols=3)


@pytest.fixture(scope="module")
def vector():
    return gym.make_vec("mazeslam/Maze-v0", num_envs=ENVS, vectorization_mode="vector_entry_point", rows=3, cols=3)


def assert_finite_step(step) -> None:
    observation, reward, _, _, info = step
    assert np.isfinite(observation["scan"]).all() and np.isfinite(observation["odometry"]).all()
    assert np.isfinite(reward).all() and np.isfinite(info["pose"]).all()


def step_or_refuse(env, action) -> None:
    """``env.step(action)``: taken, its numbers all finite; or refused in one line naming the action
    space, nothing moved, and the episode going on."""
    env.reset(seed=0)
    try:
        step = env.step(action)
    except ValueError as error:
        one_line_refusal(error)
        assert str(env.action_space) in str(error)
        assert np.all(env.unwrapped.steps == 0)  # nothing moved: the episode goes on
        step = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    assert_finite_step(step)


@FUZZ
@given(action=actions((2,)))
def test_single_env_takes_or_refuses_any_action(single, action):
    assert str(single.action_space) == "Box(-1.0, 1.0, (2,), float32)"
    step_or_refuse(single, action)


@FUZZ
@given(action=actions((ENVS, 2)))
def test_vector_env_takes_or_refuses_any_actions(vector, action):
    assert str(vector.action_space) == f"Box(-1.0, 1.0, ({ENVS}, 2), float32)"
    step_or_refuse(vector, action)


#: Values a reset option may be given.
OPTION_VALUES = st.one_of(
    st.integers(-3, 6),
    st.sampled_from([0.5, 1e300, -1e300, np.nan, np.inf, True, None, "random", "", "absent.txt", 2**70]),
    st.tuples(st.integers(-2, 5), st.integers(-2, 5)),
    st.lists(st.one_of(st.integers(-1, 4), st.floats()), max_size=3),
    st.builds(lambda row, col: np.array([row, col]), st.integers(-1, 4), st.integers(-1, 4)),
    st.floats(),
)
OPTIONS = st.dictionaries(
    st.sampled_from(["maze", "rows", "cols", "loop_fraction", "start_cell", "start_heading", "reset_mask", "bogus"]),
    OPTION_VALUES,
    max_size=3,
)
SEEDS = st.one_of(
    st.none(),
    st.integers(-5, 2**70),
    st.sampled_from([1.5, "a", True]),
    st.lists(st.one_of(st.none(), st.integers(-2, 9), st.sampled_from([1.5, "x"])), max_size=ENVS + 1),
)


def reset_or_refuse(env, seed, options, pose_of) -> None:
    """``env.reset(seed, options)``: taken, then a step; or refused with the env's pose unchanged."""
    before = pose_of().copy()
    try:
        env.reset(seed=seed, options=options)
    except (ValueError, gym.error.Error) as error:
        one_line_refusal(error)
        np.testing.assert_array_equal(pose_of(), before)
        return
    assert_finite_step(env.step(np.zeros(env.action_space.shape, dtype=np.float32)))


@FUZZ
@given(seed=SEEDS, options=OPTIONS)
def test_single_env_resets_or_refuses_any_seed_and_options(single, seed, options):
    single.reset(seed=0)
    reset_or_refuse(single, seed, options, lambda: single.unwrapped.simulated.pose)


@FUZZ
@given(seed=SEEDS, options=OPTIONS, mask=st.one_of(st.none(), hnp.arrays(np.bool_, st.sampled_from([(ENVS,), (2,)]))))
def test_vector_env_resets_or_refuses_any_seed_and_options(vector, seed, options, mask):
    vector.reset(seed=0)
    if mask is not None:
        options = {**options, "reset_mask": mask}
    reset_or_refuse(vector, seed, options, lambda: vector.unwrapped.poses)


# -- what the fuzz found ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "action", [[10**400, 0.0], np.array([1 + 2j, 0.0]), np.array([0.5, 0.5], dtype=np.complex64)], ids=str
)
def test_an_integer_beyond_any_float_or_a_complex_action_is_refused(single, action):
    """Were: OverflowError ("int too large to convert to float") and numpy's ComplexWarning."""
    single.reset(seed=0)
    with pytest.raises(ValueError, match=r"is not an array of numbers: the action space is Box"):
        single.step(action)


@pytest.mark.parametrize(
    "seed, message",
    [
        (1.5, "seed must be None, a whole number >= 0 or a list of num_envs=3 seeds, got 1.5"),
        ("abc", "seed must be None, a whole number >= 0 or a list of num_envs=3 seeds, got 'abc'"),
        ([0, -1, 2], "each seed of the list must be None or a whole number >= 0, got -1"),
    ],
)
def test_vector_env_refuses_a_bad_seed_before_resetting_any_env(vector, seed, message):
    """Were: TypeError ("object of type 'float' has no len()"), a seed list's length for a string,
    and env 0 reset before env 1's seed failed in Gymnasium's seeding."""
    vector.reset(seed=0)
    before = vector.unwrapped.poses.copy()
    with pytest.raises(ValueError) as refused:
        vector.reset(seed=seed, options={"start_cell": (2, 2)})
    assert str(refused.value) == message
    np.testing.assert_array_equal(vector.unwrapped.poses, before)


def test_a_vector_env_started_heading_0_casts_quietly(vector):
    """Was: 'divide by zero' from a ray along an axis (heading 0, a beam at 0 or pi) in the cast."""
    vector.reset(seed=0, options={"start_heading": 0})
    assert_finite_step(vector.step(np.zeros((ENVS, 2), dtype=np.float32)))
