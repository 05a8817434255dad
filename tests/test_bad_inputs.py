"""Issue #33, section 5: plain numbers and wrong types give a ModelError naming the argument, never a raw exception.

Each test is one reproduction of the issue; each failed before its fix with
the raw exception (or the silent acceptance) named in its docstring.
"""

import pathlib

import numpy as np
import pytest
from attrs import frozen

import flexmb as fm

SCENES = pathlib.Path(fm.__file__).parent / "scene" / "builtin"


def pendulum(*extra):
    m = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    pin = fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1))
    m.add(pin, fm.Gravity((0, -9.81, 0)), *extra)
    return m


# ----------------------------------------------------------------------------- generalized_alpha

@pytest.mark.parametrize("kw, match", [
    (dict(rho_inf=-1), r"generalized-alpha: rho_inf must be in \[0, 1\], got -1"),
    (dict(rho_inf=1.5), r"rho_inf must be in \[0, 1\]"),
    (dict(rho_inf=float("nan")), "rho_inf must be a finite number"),
    (dict(rho_inf="high"), "rho_inf must be a number, got 'high'"),
    (dict(rho_inf=None), "rho_inf must be a number, got None"),
    (dict(rho_inf=[0.5]), r"rho_inf must be a number, got \[0.5\]"),
    (dict(rho_inf=0.5j), "rho_inf must be a number"),
    (dict(fixed_step=-1e-3), "generalized_alpha: fixed_step must be > 0, got -0.001"),
    (dict(fixed_step="1e-3"), "fixed_step must be a number"),
    (dict(f_max=float("inf")), "f_max must be a finite number"),
    (dict(min_step=0.0), "min_step must be > 0"),
    (dict(min_step=10**400), "min_step must be a number"),
])
def test_generalized_alpha_arguments(kw, match):
    """``fm.generalized_alpha(rho_inf=-1)`` raised a bare ValueError (and TypeError for None, a list)."""
    with pytest.raises(fm.ModelError, match=match):
        fm.generalized_alpha(**kw)


# ----------------------------------------------------------------------------- bodies

def test_slender_bar_length_overflowing_the_inertia():
    """``slender_bar(length=1e300)``: OverflowError from ``length**2``."""
    with pytest.raises(fm.ModelError, match=r"slender_bar 'b': its transverse inertia m l\^2 / 12 \(inf\) is "
                                            r"beyond 1.34e\+154, .* \(length = 1e\+300 m\)"):
        fm.RigidBody.slender_bar("b", 1.0, 1e300)


def test_slender_bar_axis_as_a_float():
    """``slender_bar(axis=0.0)``: IndexError (0.0 in (0, 1, 2), then an array indexed by a float)."""
    bar = fm.RigidBody.slender_bar("b", 2.0, 1.0, axis=1.0)
    assert bar.com.tolist() == [0.0, 0.5, 0.0] and bar.inertia[1, 1] == 0.0
    with pytest.raises(fm.ModelError, match="axis must be 0, 1 or 2, got 0.5"):
        fm.RigidBody.slender_bar("b", 2.0, 1.0, axis=0.5)
    with pytest.raises(fm.ModelError, match="axis must be 0, 1 or 2, got nan"):
        fm.RigidBody.slender_bar("b", 2.0, 1.0, axis=float("nan"))


@pytest.mark.parametrize("centred", [float("nan"), "yes", None, 1])
def test_slender_bar_centred_must_be_a_bool(centred):
    """``slender_bar(centred=nan)`` was taken as True."""
    with pytest.raises(fm.ModelError, match="slender_bar 'b': centred must be True or False"):
        fm.RigidBody.slender_bar("b", 1.0, 1.0, centred=centred)
    assert fm.RigidBody.slender_bar("b", 1.0, 1.0, centred=np.bool_(True)).com.tolist() == [0.0, 0.0, 0.0]


# ----------------------------------------------------------------------------- flexible bodies

STEEL = fm.Material.steel()
BLADE = fm.Section.rectangular(0.01, 0.002)


@pytest.mark.parametrize("field", ["clamped", "rotary_inertia"])
@pytest.mark.parametrize("value", ["abc", "False", float("nan"), None, 0])
def test_flexible_body_flags_must_be_bools(field, value):
    """``FlexibleBody(clamped="abc")`` was accepted as truthy (``converter=bool``)."""
    with pytest.raises(fm.ModelError, match=f"FlexibleBody 'b': {field} must be True or False"):
        fm.FlexibleBody("b", 1.0, BLADE, STEEL, 4, **{field: value})


def test_joint_cut_must_be_a_bool():
    """``Revolute(cut="no")`` was a cut joint (``converter=bool``)."""
    with pytest.raises(fm.ModelError, match="Revolute 'pin': cut must be True or False, got 'no'"):
        fm.Revolute("pin", "ground", "bar", cut="no")


@pytest.mark.parametrize("frequency, match", [
    (-np.inf, "frequency must be a finite number > 0, got -inf"),
    (0.0, "frequency must be a finite number > 0, got 0.0"),
    (float("nan"), "frequency must be a finite number > 0"),
    ("10 Hz", "frequency must be a finite number > 0"),
])
def test_uniform_beam_frequency(frequency, match):
    """``uniform_beam(frequency=-inf)`` was accepted (a damping beta of -0.0)."""
    with pytest.raises(fm.ModelError, match=f"FlexibleBody 'b': {match}"):
        fm.FlexibleBody.uniform_beam("b", 1.0, BLADE, STEEL, 4, damping_ratio=0.02, frequency=frequency)


@pytest.mark.parametrize("ratio", [-0.1, float("nan"), "2%", None])
def test_uniform_beam_damping_ratio(ratio):
    with pytest.raises(fm.ModelError, match="FlexibleBody 'b': damping_ratio must be"):
        fm.FlexibleBody.uniform_beam("b", 1.0, BLADE, STEEL, 4, damping_ratio=ratio)


@pytest.mark.parametrize("kw, what", [
    (dict(Iy=1e300), "segment inertia"), (dict(Iz=1e300), "segment inertia"),
    (dict(J=1e300), "joint stiffness"), (dict(area=1e300), "segment mass"),
])
def test_section_values_overflowing_the_equations(kw, what):
    """``Section(Iy=1e300)`` in a beam: LinAlgError ('Array must not contain infs or NaNs') from the first run."""
    data = dict(area=1e-4, Iy=1e-8, Iz=1e-8, J=1e-8) | kw
    with pytest.raises(fm.ModelError, match=f"FlexibleBody 'beam': its {what} .* is beyond 1.34e\\+154"):
        fm.FlexibleBody("beam", 1.0, fm.Section(**data), STEEL, 4, keep=("bend_y", "bend_z", "torsion"))


def test_flexible_length_overflowing_the_shear_springs():
    """``length=1e300`` with shear kept: OverflowError from ``l**3``."""
    with pytest.raises(fm.ModelError, match="FlexibleBody 'beam': its segment"):
        fm.FlexibleBody("beam", 1e300, BLADE, STEEL, 2, keep=("shear_y",))


# ----------------------------------------------------------------------------- simulate, analyses

@pytest.mark.parametrize("kw, match", [
    (dict(positions=-1.0), "positions must be a dict"),
    (dict(speeds=[1.0]), "speeds: an entry must be a dict, a PointVelocity or an AngularVelocity"),
    (dict(positions={"pin": "high"}), "initial position 'pin' must be a number or 1 numbers"),
    (dict(positions={"pin": [1.0, 2.0]}), "initial position 'pin' must be a number or 1 numbers"),
    (dict(positions={3: 1.0}), "expected a Joint or its name, got int"),
    (dict(fixed=1.0), "fixed must be a list"),
    (dict(fixed="pin"), "fixed must be a list"),
])
def test_simulate_initial_conditions_of_the_wrong_type(kw, match):
    """``simulate(positions=-1.0)``: AttributeError ('float' object has no attribute 'items')."""
    with pytest.raises(fm.ModelError, match=match):
        fm.simulate(pendulum(), 0.1, progress=False, **kw)


@pytest.fixture(scope="module")
def spring_ss():
    m = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    pin = fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1))
    system = m.add(pin, fm.JointSpringDamper("spring", pin, 3.0, 0.1)).build()
    return fm.state_space(system, ["pin"], ["pin"])


@pytest.mark.parametrize("kw, match", [
    (dict(w=np.nan), r"w must be finite, got w\[0\] = nan"),
    (dict(w=[1.0, np.inf]), r"w must be finite, got w\[1\] = inf"),
    (dict(f=[np.nan]), r"f must be finite, got f\[0\] = nan"),
    (dict(w="fast"), "w must be an array of real numbers"),
    (dict(w=[1j]), "w must be an array of real numbers"),
    (dict(w=[[1.0, 2.0]]), "w must be a 1-d array"),
    (dict(w=[]), "w must be a 1-d array"),
    (dict(n=0), "n must be an integer >= 1, got 0"),
    (dict(n=None), "n must be an integer >= 1, got None"),
])
def test_frequency_response_frequencies(spring_ss, kw, match):
    """``frequency_response(w=nan)`` returned NaN silently."""
    with pytest.raises(fm.ModelError, match=f"frequency_response: {match}"):
        fm.frequency_response(spring_ss, **kw)


def test_frequency_response_refuses_more_frequencies_than_it_can_evaluate(spring_ss):
    """``n=10**18`` raised a raw MemoryError; ``n=10**9`` ran for hours (a Python-level solve per frequency)."""
    from flexmb.analysis.statespace import MAX_FREQUENCIES

    with pytest.raises(fm.ModelError, match=r"frequency_response: 1e\+18 frequencies, more than the 1,000,000"):
        fm.frequency_response(spring_ss, n=10**18)
    with pytest.raises(fm.ModelError, match=r"frequency_response: 1e\+09 frequencies"):
        fm.frequency_response(spring_ss, n=10**9)
    with pytest.raises(fm.ModelError, match=r"StateSpace.response: 1e\+06 frequencies"):
        spring_ss.response(1j * np.linspace(1.0, 2.0, MAX_FREQUENCIES + 1))
    assert fm.frequency_response(spring_ss, n=MAX_FREQUENCIES // 1000).w.shape == (MAX_FREQUENCIES // 1000,)


# ----------------------------------------------------------------------------- a force plugin that raises

@frozen(eq=False)
class Boom(fm.ForceElement):
    """Raises (as a plugin's bug would) once t passes ``t_fail``."""

    t_fail: float = 0.05
    error: type = RuntimeError

    def apply(self, state, loads):
        if state.t > self.t_fail:
            raise self.error("plugin exploded")


METHODS = ["DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA", "CVODE_BDF", "CVODE_Adams", "IDA", "GeneralizedAlpha"]


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("error", [RuntimeError, KeyError])
def test_raising_force_plugin_fails_the_run_with_every_integrator(method, error):
    """A raising plugin escaped raw from 6 of 10 integrators (CVODE/IDA wrapped only a RuntimeError)."""
    with pytest.raises(fm.SimulationError) as info:
        fm.simulate(pendulum(Boom("boom", error=error)), 0.1, positions={"pin": 0.5}, method=method,
                    rtol=1e-6, progress=False)
    err = info.value
    assert f"force element 'boom' (Boom) failed: {error.__name__}: " in str(err)
    assert "plugin exploded" in str(err)
    assert 0.05 < err.t < 0.1 and f"at t = {err.t:.9g} s" in str(err)
    assert err.result is not None and err.result.t[-1] <= err.t and len(err.result.t) >= 10
    assert isinstance(err.__cause__, fm.AssemblyError) and isinstance(err.__cause__.__cause__, error)


def test_raising_force_plugin_named_among_others_of_its_class():
    with pytest.raises(fm.AssemblyError, match=r"force element 'late' \(Boom\) failed: RuntimeError"):
        s = pendulum(Boom("early", t_fail=1.0), Boom("late", t_fail=0.5)).build()
        s.accelerations(0.7, np.zeros(1), np.zeros(1))


def test_wiper_with_an_absurd_blade_width():
    """A wiper scene with ``b = 1e10``: LinAlgError ('5-th leading minor ...') from the Cholesky in state_jacobian."""
    text = (SCENES / "wiper.toml").read_text().replace("b = 0.01 ", "b = 1e10 ")
    scene = fm.loads_scene(text, "wiper.toml")
    with pytest.raises(fm.AssemblyError, match="reduced mass matrix T\\^T A T is not positive definite at t = 0 s; "
                                               "its diagonal spans .* beyond what double precision resolves"):
        scene.info()


def test_a_pendulum_spinning_at_1e30_rad_per_s_is_refused_before_it_runs():
    """``speeds={"pin": 1e30}`` ran for ever: some 1e28 turns for DOP853 to resolve, no up-front bound counted them."""
    with pytest.raises(fm.ModelError, match=r"simulate: coordinate 'pin.angle' turning at 1e\+30 rad/s \(1.59e\+29 "
                                            r"turns, a step or more each\) needs at least 1.59e\+29 steps over "
                                            r"\[0, 1\] s, more than max_steps = 1e\+09"):
        fm.simulate(pendulum(), 1.0, speeds={"pin": 1e30}, progress=False)
    # an angle no float resolves (the spring then drives it to some 1e15 rad/s)
    m = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    pin = fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1))
    m.add(pin, fm.JointSpringDamper("spring", pin, 3.0, 0.0))
    with pytest.raises(fm.ModelError, match=r"coordinate 'pin.angle' = 1e\+30 rad is beyond what a float resolves "
                                            r"\(neighbouring floats 1.41e\+14 rad apart\); give the angle modulo 2 pi"):
        fm.simulate(m, 0.01, positions={"pin": 1e30}, progress=False)
    # a fast run within the bound still runs, and max_steps moves the bound
    res = fm.simulate(pendulum(), 0.01, speeds={"pin": 1e3}, rtol=1e-6, progress=False)
    assert res.status == "finished"
    with pytest.raises(fm.ModelError, match="turning at 1e\\+05 rad/s"):
        fm.simulate(pendulum(), 1.0, speeds={"pin": 1e5}, max_steps=1e4, progress=False)


# ----------------------------------------------------------------------------- a blow-up, named as such

@frozen(eq=False)
class Push(fm.ForceElement):
    """``F = +k r``: pushes the body away from the origin, harder the farther it is (a negative stiffness)."""

    body: fm.Body = fm.reference(fm.Body)
    k: float = 1e12

    def apply(self, state, loads):
        i = state.index(self.body)
        loads.add_point_force(i, state.r[i], self.k * state.r[i])


def slider(sparse=None):
    m = fm.Model()
    b = fm.RigidBody("blk", 1.0, (1, 1, 1))
    m.add(fm.Prismatic("slide", m.ground, b, axis=(1, 0, 0)), Push("push", b))
    return m.build(sparse=sparse)


OVERFLOW = (r"the state overflowed: {what} \(beyond 1.34e\+154, where products in the equations overflow\); "
            r"force element 'push' \(Push\) gives the largest load - the motion grows without bound")


@pytest.mark.parametrize("sparse", [None, False])
def test_overflowing_state_is_named_not_a_singular_mass_matrix(sparse):
    """A state past the range of floats was reported as 'the mass matrix is singular ... moves no mass'."""
    s = slider(sparse)
    with pytest.raises(fm.AssemblyError, match=OVERFLOW.format(what="coordinate 'slide.slide' = 1e\\+200")):
        s.accelerations(0.0, np.array([1e200]), np.zeros(1))
    assert np.isfinite(s.accelerations(0.0, np.array([1.0]), np.array([1e250]))).all()  # a fast slide is no failure


@pytest.mark.parametrize("method", ["DOP853", "LSODA", "CVODE_BDF", "IDA", "BDF"])
def test_blow_up_diagnosed_by_every_integrator(method):
    """``F = +1e12 x`` overflowed the state and every method said 'the mass matrix is singular'."""
    m = fm.Model()
    b = fm.RigidBody("blk", 1.0, (1, 1, 1))
    m.add(fm.Prismatic("slide", m.ground, b, axis=(1, 0, 0)), Push("push", b))
    with pytest.raises(fm.SimulationError, match=OVERFLOW.format(what=".*'slide.slide' = [\\d.]+e\\+\\d+")) as info:
        fm.simulate(m, 0.1, positions={"slide": 0.1}, method=method, rtol=1e-4, progress=False)
    assert 3e-4 < info.value.t < 4e-4 and "singular" not in str(info.value)


# ----------------------------------------------------------------------------- info no denser than a run

def test_info_of_an_open_tree_builds_no_n_by_n_matrix(monkeypatch):
    """``flexmb info`` on 100,000 segments: MemoryError from np.eye(n) in the complement of a model without rows."""
    from flexmb._describe import counts
    from flexmb.complements.base import ComplementStrategy

    def no_complement(self, psi):
        raise AssertionError("counts built a complement")

    m = fm.Model()
    beam = fm.FlexibleBody.uniform_beam("beam", length=1.0, section=fm.Section.rectangular(0.02, 0.005),
                                        material=fm.Material.aluminium(), n_segments=6)
    m.add(fm.Fixed("clamp", m.ground, beam))
    system = m.build()
    monkeypatch.setattr(ComplementStrategy, "complement", no_complement)
    n = system.n_coords
    assert counts(system, np.zeros(n), np.zeros(n)) == (0, 0, n)


def test_a_scene_builds_its_system_once(monkeypatch):
    """``flexmb info`` and ``flexmb run`` built the model twice (the loader's checks, then the command)."""
    builds = []
    build = fm.Model.build

    def counted(self, **options):
        builds.append(options)
        return build(self, **options)

    monkeypatch.setattr(fm.Model, "build", counted)
    scene = fm.load_scene(SCENES / "fourbar.toml")
    scene.info()
    scene.simulate(t_end=0.01, n_out=2)
    assert len(builds) == 1


# ----------------------------------------------------------------------------- scene files bounded up front

def test_a_fifo_is_no_scene_file(tmp_path):
    """``flexmb info`` on a FIFO blocked for ever (open() waits for a writer)."""
    import os

    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    with pytest.raises(fm.SceneError, match=r"scene.toml: not a regular file"):
        fm.load_scene(fifo)


def test_a_key_of_50000_parts_is_refused_before_parsing():
    """A 50,000-part dotted key kept tomllib busy for about 100 s."""
    text = '[model]\nname = "x"\n' + ".".join(["a"] * 50_000) + " = 1\n"
    with pytest.raises(fm.SceneError, match=r"line 3: a dotted key of 50,000 parts, more than the 64"):
        fm.loads_scene(text, "deep.toml")
    # a value's continuation line (numbers with 100 decimal points) is no key
    from flexmb.scene.load import _check_key_parts

    _check_key_parts("x = [\n" + ", ".join(["0.5"] * 100) + ",\n]\n[a.b]\n", "values.toml")


@pytest.mark.parametrize("label", ["..", ".hidden", "../../evil", "a/b"])
def test_a_run_named_as_a_path_is_refused_when_the_scene_is_read(label):
    """``[runs."../../evil"]`` was refused only after the simulation, ``[runs.".."]`` and ``.hidden`` never."""
    text = (SCENES / "fourbar.toml").read_text() + f'\n[runs."{label}"]\n"solver.t_end" = 0.1\n'
    with pytest.raises(fm.SceneError, match=r"a run's name must start with a letter, digit or _ and hold only"):
        fm.loads_scene(text, "fourbar.toml")


def test_rates_of_a_large_looped_model_need_no_dense_eigenvalues(monkeypatch):
    """``flexmb info`` on a wiper with 1,500-segment blades ran 300 s to 4.5 GB: dense eigenvalues of P K and
    P C (three times). Above DENSE_RATES_MAX coordinates the largest ones come by Arnoldi iteration, once."""
    from flexmb.system import rates

    text = (SCENES / "wiper.toml").read_text().replace("n_segments = 6", "n_segments = 60")
    scene = fm.loads_scene(text, "wiper.toml")
    system = scene.system()
    x, xd = scene.initial_state(system)
    n = system.n_coords
    assert n > rates.DENSE_RATES_MAX
    J = system.state_jacobian(0.0, x, xd, geometric=False)
    dense = (np.sqrt(np.max(np.linalg.eigvals(-J[n:, :n]).real)), np.max(np.abs(np.linalg.eigvals(-J[n:, n:]))))

    def refused(*args, **kwargs):
        raise AssertionError("dense eigenvalues")

    monkeypatch.setattr(np.linalg, "eigvals", refused)
    calls = []
    at = type(system)._rates_at
    monkeypatch.setattr(type(system), "_rates_at", lambda self, *a: calls.append(a) or at(self, *a))
    w = system.highest_frequency(0.0, x, xd), system.fastest_rate(0.0, x, xd)
    assert len(calls) == 1  # the second call takes the kept rates
    np.testing.assert_allclose(w, (dense[0], max(dense)), rtol=1e-3)
