"""Issue #33, section 5: the fuzz matrix. Every public constructor, ``simulate`` argument and analysis, given
one absurd value (0, tiny, 1e30, nan, inf, None, a string, a list, a complex, a 2 x 2 array, 10**400),
answers with a FlexmbError or a result: never a raw exception, never a hang (each case under an alarm).

The full sweep takes a few seconds; a hypothesis test adds random values of every type.
"""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import flexmb as fm
from strategies import alarm

BAD = [0, 0.0, -1.0, 1e-300, 1e30, 1e300, float("nan"), float("inf"), -float("inf"), None, "abc", [1.0], [],
       1j, np.ones((2, 2)), 10**400, True]

STEEL = fm.Material.steel()
BLADE = fm.Section.rectangular(0.01, 0.002)


def _pendulum():
    m = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    pin = fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1))
    m.add(pin, fm.Gravity((0, -9.81, 0)), fm.JointSpringDamper("spring", pin, 3.0, 0.1))
    return m


SYSTEM = _pendulum().build()
X0 = np.array([0.3])


def _model_with(*elements):
    m = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    m.add(fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1)), *elements)
    return m.build()


#: name -> call(value): one argument of one public function replaced by the bad value
TARGETS = {
    "RigidBody.mass": lambda v: fm.RigidBody("b", mass=v),
    "RigidBody.inertia": lambda v: fm.RigidBody("b", inertia=v),
    "RigidBody.com": lambda v: fm.RigidBody("b", com=v),
    "slender_bar.mass": lambda v: fm.RigidBody.slender_bar("b", v, 1.0),
    "slender_bar.length": lambda v: fm.RigidBody.slender_bar("b", 1.0, v),
    "slender_bar.axis": lambda v: fm.RigidBody.slender_bar("b", 1.0, 1.0, axis=v),
    "slender_bar.centred": lambda v: fm.RigidBody.slender_bar("b", 1.0, 1.0, centred=v),
    "bar.vector": lambda v: fm.RigidBody.bar("b", 1.0, v),
    "box.size": lambda v: fm.RigidBody.box("b", 1.0, v),
    "Section.area": lambda v: fm.Section(v, 1e-8, 1e-8, 1e-8),
    "Section.Iy": lambda v: fm.Section(1e-4, v, 1e-8, 1e-8),
    "Section.c_y": lambda v: fm.Section(1e-4, 1e-8, 1e-8, 1e-8, c_y=v),
    "Section.rectangular": lambda v: fm.Section.rectangular(v, 0.002),
    "Section.circular": lambda v: fm.Section.circular(v),
    "Section.tube": lambda v: fm.Section.tube(0.02, v),
    "Material.E": lambda v: fm.Material(v, 7850.0),
    "Material.density": lambda v: fm.Material(210e9, v),
    "Material.nu": lambda v: fm.Material(210e9, 7850.0, nu=v),
    "Material.G": lambda v: fm.Material(210e9, 7850.0, G=v),
    "FlexibleBody.length": lambda v: fm.FlexibleBody("f", v, BLADE, STEEL, 4),
    "FlexibleBody.section": lambda v: fm.FlexibleBody("f", 1.0, v, STEEL, 4),
    "FlexibleBody.n_segments": lambda v: fm.FlexibleBody("f", 1.0, BLADE, STEEL, v),
    "FlexibleBody.keep": lambda v: fm.FlexibleBody("f", 1.0, BLADE, STEEL, 4, keep=v),
    "FlexibleBody.damping": lambda v: fm.FlexibleBody("f", 1.0, BLADE, STEEL, 4, damping=v),
    "FlexibleBody.clamped": lambda v: fm.FlexibleBody("f", 1.0, BLADE, STEEL, 4, clamped=v),
    "uniform_beam.damping_ratio": lambda v: fm.FlexibleBody.uniform_beam("f", 1.0, BLADE, STEEL, 4,
                                                                         damping_ratio=v),
    "uniform_beam.frequency": lambda v: fm.FlexibleBody.uniform_beam("f", 1.0, BLADE, STEEL, 4,
                                                                     damping_ratio=0.02, frequency=v),
    "Revolute.axis": lambda v: fm.Revolute("j", "a", "b", axis=v),
    "Revolute.parent_point": lambda v: fm.Revolute("j", "a", "b", parent_point=v),
    "Revolute.parent_frame": lambda v: fm.Revolute("j", "a", "b", parent_frame=v),
    "Revolute.cut": lambda v: fm.Revolute("j", "a", "b", cut=v),
    "Prismatic.axis": lambda v: fm.Prismatic("j", "a", "b", axis=v),
    "Universal.axis2": lambda v: fm.Universal("j", "a", "b", axis2=v),
    "Spherical.child_point": lambda v: fm.Spherical("j", "a", "b", child_point=v),
    "Gravity.g": lambda v: fm.Gravity(v),
    "SpringDamper.stiffness": lambda v: fm.SpringDamper("s", "a", (0, 0, 0), "b", (0, 0, 0), stiffness=v),
    "SpringDamper.damping": lambda v: fm.SpringDamper("s", "a", (0, 0, 0), "b", (0, 0, 0), 1.0, damping=v),
    "SpringDamper.rest_length": lambda v: fm.SpringDamper("s", "a", (0, 0, 0), "b", (0, 0, 0), 1.0,
                                                          rest_length=v),
    "SpringDamper.point1": lambda v: fm.SpringDamper("s", "a", v, "b", (0, 0, 0), 1.0),
    "JointSpringDamper.stiffness": lambda v: fm.JointSpringDamper("s", "pin", v),
    "JointSpringDamper.rest": lambda v: fm.JointSpringDamper("s", "pin", 1.0, rest=v),
    "PointForce.force": lambda v: fm.PointForce("p", "bar", v),
    "PointForce.point": lambda v: fm.PointForce("p", "bar", (1.0, 0, 0), point=v),
    "BodyTorque.torque": lambda v: fm.BodyTorque("t", "bar", v),
    "Driver.speed": lambda v: fm.Driver.constant_speed("d", "pin", speed=v),
    "in a model: Gravity.g": lambda v: _model_with(fm.Gravity(v)),
    "in a model: PointForce.force": lambda v: _model_with(fm.PointForce("p", "bar", v)),
    "generalized_alpha.rho_inf": lambda v: fm.generalized_alpha(rho_inf=v),
    "generalized_alpha.fixed_step": lambda v: fm.generalized_alpha(fixed_step=v),
    "generalized_alpha.min_step": lambda v: fm.generalized_alpha(min_step=v),
    "PathOptions.step": lambda v: fm.PathOptions(step=v),
    "PathOptions.max_steps": lambda v: fm.PathOptions(max_steps=v),
    "simulate.t_end": lambda v: fm.simulate(SYSTEM, v, n_out=3, progress=False),
    "simulate.t0": lambda v: fm.simulate(SYSTEM, 0.01, t0=v, n_out=3, progress=False),
    "simulate.n_out": lambda v: fm.simulate(SYSTEM, 0.01, n_out=v, progress=False),
    "simulate.t_eval": lambda v: fm.simulate(SYSTEM, 0.01, t_eval=v, progress=False),
    "simulate.rtol": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, rtol=v, progress=False),
    "simulate.atol": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, atol=v, progress=False),
    "simulate.max_step": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, max_step=v, progress=False),
    "simulate.max_steps": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, max_steps=v, progress=False),
    "simulate.projection_tol": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, projection_tol=v, progress=False),
    "simulate.method": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, method=v, progress=False),
    "simulate.positions": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, positions=v, progress=False),
    "simulate.positions[pin]": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, positions={"pin": v}, progress=False),
    "simulate.speeds[pin]": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, speeds={"pin": v}, progress=False),
    "simulate.x0": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, x0=v, progress=False),
    "simulate.fixed": lambda v: fm.simulate(SYSTEM, 0.01, n_out=3, fixed=v, progress=False),
    "linearize.x0": lambda v: fm.linearize(SYSTEM, x0=v),
    "linearize.t": lambda v: fm.linearize(SYSTEM, x0=X0, t=v),
    "modes.n_modes": lambda v: fm.modes(SYSTEM, n_modes=v, x0=X0),
    "linear_statics.x0": lambda v: fm.linear_statics(SYSTEM, x0=v),
    "static_equilibrium.tol": lambda v: fm.static_equilibrium(SYSTEM, x0=X0, tol=v),
    "static_equilibrium.max_iter": lambda v: fm.static_equilibrium(SYSTEM, x0=X0, max_iter=v),
    "state_space.inputs": lambda v: fm.state_space(SYSTEM, v, ["pin"]),
    "state_space.outputs": lambda v: fm.state_space(SYSTEM, ["pin"], v),
    "frequency_response.w": lambda v: fm.frequency_response(fm.state_space(SYSTEM, ["pin"], ["pin"]), w=v),
    "frequency_response.n": lambda v: fm.frequency_response(fm.state_space(SYSTEM, ["pin"], ["pin"]), n=v),
}

#: cases that still hang, to be fixed (kept out so that the test guards the rest); a pendulum turning at
#: 1e30 rad/s, or driven there by its spring from 1e30 rad, is refused by the turns' bound of simulate
KNOWN: set = set()


def _check(target, value):
    """The call answers with a FlexmbError or a value, within the alarm; anything else fails the test."""
    with alarm(20.0), np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            TARGETS[target](value)
        except fm.FlexmbError:
            pass
        except Exception as exc:  # a raw exception: the finding
            pytest.fail(f"{target} = {value!r}: raw {type(exc).__name__}: {exc}")


#: any value at all: numbers of every size and sign, NaN, inf, text, None, lists, complex numbers, arrays
VALUES = st.one_of(
    st.floats(), st.integers(-10**400, 10**400), st.text(max_size=5), st.none(), st.booleans(),
    st.complex_numbers(), st.lists(st.floats(), max_size=4),
    st.sampled_from([np.ones((2, 2)), np.array([1.0, np.nan, 2.0]), np.float32(1e38), {"a": 1}]))


@settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(st.sampled_from(sorted(TARGETS)), VALUES)
def test_fuzz_matrix_random_values(target, value):
    """A FlexmbError or a result for any value in any argument of the matrix."""
    if not any(t == target and _same(BAD[i], value) for t, i in KNOWN):
        _check(target, value)


@pytest.mark.parametrize("target", sorted(TARGETS))
def test_fuzz_matrix_full(target):
    """The whole matrix: every target with every value of BAD (about 2 s)."""
    for i, value in enumerate(BAD):
        if (target, i) not in KNOWN:
            _check(target, value)


def _same(a, b):
    return type(a) is type(b) and isinstance(a, float) and a == b
