"""Every public function that hands a state to the compiled kernels checks it first (issue #33, section 1).

The kernels run without bounds checks, so a state of the wrong length used
to be read or written past its end: ``linearize`` with 3 coordinates on a
4-coordinate model aborted the interpreter ("corrupted size vs.
prev_size"), ``System.accelerations`` with a state of length 1 double-freed,
``System.kinematics`` with length 3 returned garbage. Here each entry gets
wrong lengths, wrong ranks, wrong types and non-finite values, and must
raise a ModelError naming the function and the argument (a crash would take
the test process down with it); right values given as lists still work.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import flexmb as fm
from flexmb.errors import ModelError

from conftest import fourbar, fourbar_initial, slender_pendulum_chain


def _systems():
    chain = slender_pendulum_chain(4).build()
    looped = {name: fourbar().build(complement=name) for name in ("articulated", "svd")}
    return {"open tree": chain, **{f"four-bar, {k}": s for k, s in looped.items()}}


SYSTEMS = _systems()


def _consistent(system):
    """A state on the constraints, as lists (the public functions take array_like)."""
    n = system.n_coords
    if system.n_constraints:
        x, xd = fm.initial_state(system, positions=fourbar_initial(), speeds={"A": 1.0})
        return list(x), list(xd)
    return [0.1] * n, [0.0] * n


#: (name, call(system, t, x, xd) -> anything); each takes x and xd of n entries
ENTRIES = {
    "System.kinematics": lambda s, t, x, xd: s.kinematics(t, x, xd),
    "System.equations": lambda s, t, x, xd: s.equations(t, x, xd),
    "System.accelerations": lambda s, t, x, xd: s.accelerations(t, x, xd),
    "System.constraint_residuals": lambda s, t, x, xd: s.constraint_residuals(t, x, xd),
    "System.constraint_residual": lambda s, t, x, xd: s.constraint_residual(t, x, xd),
    "System.project": lambda s, t, x, xd: s.project(t, x, xd),
    "System.reactions": lambda s, t, x, xd: s.reactions(t, x, xd),
    "System.energy": lambda s, t, x, xd: s.energy(t, x, xd),
    "System.highest_frequency": lambda s, t, x, xd: s.highest_frequency(t, x, xd),
    "System.fastest_rate": lambda s, t, x, xd: s.fastest_rate(t, x, xd),
    "System.state_jacobian": lambda s, t, x, xd: s.state_jacobian(t, x, xd),
    "System.dof": lambda s, t, x, xd: s.dof(t, x),
    "linearize": lambda s, t, x, xd: fm.linearize(s, x, xd, t),
    "modes": lambda s, t, x, xd: fm.modes(s, x0=x, xd0=xd, t=t),
    "linear_statics": lambda s, t, x, xd: fm.linear_statics(s, x, t),
    "static equilibrium": lambda s, t, x, xd: fm.static_equilibrium(s, x, t, continuation=False),
    "state_space": lambda s, t, x, xd: fm.state_space(s, about=(x, xd, t)),
    "initial state": lambda s, t, x, xd: fm.initial_state(s, t, x0=x, xd0=xd),
}

#: entries where ``None`` means "the default state" (zeros, or the given positions)
OPTIONAL = {"System.dof", "linearize", "modes", "linear_statics", "static equilibrium", "state_space",
            "initial state"}

#: entries that take the whole state y = (x, xd)
Y_ENTRIES = {
    "System.state_rate": lambda s, t, y: s.state_rate(t, y),
    "System.reduced_parts": lambda s, t, y: s.reduced_parts(t, y),
}


def _wrong_shapes(n):
    """Lengths and ranks a caller gets wrong: empty, short, long, a column, a matrix."""
    return [np.zeros(0), np.zeros(1), np.zeros(n - 1), np.zeros(n + 1), np.zeros(2 * n), np.zeros((n, 1)),
            np.zeros((1, n)), np.zeros((n, n)), np.float64(0.0)]


def _wrong_values(n):
    """Values of the right length that are not a state: non-finite, complex, text, nothing."""
    nan, inf = np.zeros(n), np.zeros(n)
    nan[-1], inf[0] = np.nan, -np.inf
    return [nan, inf, np.zeros(n, complex) + 1j, ["a"] * n, "abcd"[:n], None, {"x": 1}]


def _expect_model_error(call, where, what):
    with pytest.raises(ModelError) as info:
        call()
    msg = str(info.value)
    assert where in msg and what in msg, msg


@pytest.mark.parametrize("model", list(SYSTEMS))
@pytest.mark.parametrize("entry", list(ENTRIES))
def test_wrong_shapes_and_values_are_refused_before_any_kernel(model, entry):
    s = SYSTEMS[model]
    call = ENTRIES[entry]
    x, xd = _consistent(s)
    n = s.n_coords
    for bad in _wrong_shapes(n) + _wrong_values(n):
        if bad is None and entry in OPTIONAL:
            continue
        _expect_model_error(lambda: call(s, 0.0, bad, xd), "", "x")
        if entry not in ("System.dof", "linear_statics", "static equilibrium"):  # take no speeds
            _expect_model_error(lambda: call(s, 0.0, x, bad), "", "xd")
    for t in (np.nan, np.inf, "0", None, [0.0]):
        if entry in ("initial state",):
            continue  # t0 is checked by simulate_arguments for a run, and by the projection here
        _expect_model_error(lambda: call(s, t, x, xd), "", "t")


@pytest.mark.parametrize("model", list(SYSTEMS))
@pytest.mark.parametrize("entry", list(Y_ENTRIES))
def test_wrong_whole_states_are_refused(model, entry):
    s = SYSTEMS[model]
    call = Y_ENTRIES[entry]
    n = s.n_coords
    for bad in _wrong_shapes(2 * n) + _wrong_values(2 * n):
        if entry == "System.reduced_parts" and np.ndim(bad) == 1 and np.size(bad) > 2 * n:
            continue  # documented: y may carry more than (x, xd) (the work integrals)
        _expect_model_error(lambda: call(s, 0.0, bad), entry, "y")


def test_the_message_names_function_argument_and_shape():
    s = SYSTEMS["open tree"]
    with pytest.raises(ModelError, match=r"System.accelerations: x must have shape \(4,\), got \(3,\)"):
        s.accelerations(0.0, np.zeros(3), np.zeros(4))
    with pytest.raises(ModelError, match=r"linearize: x0 must be finite, got x0\[2\] = nan"):
        fm.linearize(s, np.array([0.0, 0.0, np.nan, 0.0]))
    with pytest.raises(ModelError, match=r"System.project: fixed must be a boolean array of shape \(3,\)"):
        SYSTEMS["four-bar, articulated"].project(0.0, np.zeros(3), np.zeros(3), fixed=[True])


@pytest.mark.parametrize("model", list(SYSTEMS))
def test_lists_and_read_only_arrays_are_taken_as_states(model):
    """array_like states work, and give what float arrays give (the checks change no result)."""
    s = SYSTEMS[model]
    x, xd = _consistent(s)
    xa, xda = np.array(x), np.array(xd)
    ro = xa.copy()
    ro.flags.writeable = False
    expected = s.accelerations(0.0, xa, xda)
    np.testing.assert_array_equal(s.accelerations(0.0, x, xd), expected)
    np.testing.assert_array_equal(s.accelerations(0.0, ro, xda), expected)
    np.testing.assert_array_equal(s.state_rate(0.0, x + xd)[len(x):], expected)


@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_any_wrong_length_or_rank_is_refused(data):
    """Random shapes (rank 0-3, sizes 0-12) that are not (n,) never reach the kernels."""
    name = data.draw(st.sampled_from(sorted(SYSTEMS)))
    s = SYSTEMS[name]
    n = s.n_coords
    shape = data.draw(st.lists(st.integers(0, 12), min_size=0, max_size=3).filter(lambda sh: tuple(sh) != (n,)))
    bad = np.ones(shape)
    entry = data.draw(st.sampled_from(sorted(ENTRIES)))
    x, xd = _consistent(s)
    _expect_model_error(lambda: ENTRIES[entry](s, 0.0, bad, xd), "", "x")
    ybad = np.ones(data.draw(st.lists(st.integers(0, 12), min_size=0, max_size=3).filter(
        lambda sh: tuple(sh) != (2 * n,))))
    _expect_model_error(lambda: s.state_rate(0.0, ybad), "System.state_rate", "y")
