"""Contact onset and separation as integration events (#30, item 2): located, restarted at, counted; tunnelling refused.

Closed forms used below (a ball of mass m and radius r on the floor):

* Dropped from rest at a height h of its lowest point, under gravity g: it
  touches at ``sqrt(2 h / g)``; after a separation at the speed v it flies
  ``2 v / g`` and touches again at the speed v (a free flight, the floor
  at the same height at both ends).
* Launched at v against the floor without gravity, with Hertz's law
  ``F = K delta^1.5`` (no damping): it touches at ``gap / v``, separates
  ``t_c = 2 I delta_max / v`` later at the speed v, with
  ``delta_max = (5 m v^2 / (4 K))^(2/5)`` and
  ``I = int_0^1 dx / sqrt(1 - x^(5/2))`` (the energy integral).
* With the Lankarani-Nikravesh or Flores law, the rebound ratio is
  ``restitution_of_hysteresis(chi)`` (tests/test_contact.py).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.integrate import quad

import flexmb as fm
from flexmb.forces.contact import restitution_of_hysteresis

M, R, G_ACC, H = 1.0, 0.05, 9.81, 0.2
K_STEEL = fm.hertz_stiffness(R, 2.0e11, 0.3)  # steel ball on a rigid plane, N/m^1.5


def _report(name, **values):
    print(f"\n[contact events] {name}: " + ", ".join(f"{k} = {v:.6g}" for k, v in values.items()))


def _drop_model(law, gravity=True):
    model = fm.Model()
    ball = fm.RigidBody("ball", mass=M, inertia=np.eye(3) * 0.4 * M * R ** 2)
    floor = fm.SpherePlaneContact("floor", ball, R, law)
    model.add(fm.Prismatic("drop", model.ground, ball, axis=(0, 0, 1)), floor)
    if gravity:
        model.add(fm.Gravity((0, 0, -G_ACC)))
    return model


def _events(res, kind):
    return np.array([(e[0], e[3]) for e in res.contact_events if e[2] == kind]).reshape(-1, 2)


#: |located - closed form| of the first impact, s: the event tolerance (1e-13 relative) where the
#: integrator's free flight is exact (a parabola: Runge-Kutta, Radau); else its own error at rtol 1e-10
FIRST_IMPACT_TOL = {"DOP853": 1e-13, "RK45": 1e-13, "Radau": 1e-13, "CVODE_BDF": 3e-11, "GeneralizedAlpha": 3e-12}
#: relative error of a flight's duration against 2 v / g from the speed at the separation: the integration's
#: at rtol 1e-10 (the second-order generalized-alpha method's the largest)
FLIGHT_TOL = {"DOP853": 1e-10, "RK45": 1e-10, "Radau": 1e-10, "CVODE_BDF": 1e-9, "GeneralizedAlpha": 2e-7}


@pytest.mark.parametrize("method", sorted(FIRST_IMPACT_TOL))
def test_dropped_ball_impacts_at_the_closed_form_times(method):
    """Onset at sqrt(2h/g); each flight lasts 2 v/g; onsets and separations alternate and are counted."""
    res = fm.simulate(_drop_model(fm.FloresLaw(K_STEEL, 0.8)), 1.2, x0=[R + H], xd0=[0.0], method=method,
                      rtol=1e-10, progress=False)
    assert res.status == "finished"
    onsets, separations = _events(res, "onset"), _events(res, "separation")
    t1 = np.sqrt(2 * H / G_ACC)
    assert abs(onsets[0, 0] - t1) < FIRST_IMPACT_TOL[method]
    assert onsets[0, 1] == pytest.approx(G_ACC * t1, rel=1e-9)  # the impact speed, as the rate at the onset
    # the count: impacts at t1 + sum of the flights 2 e^k v1 / g (the contacts last ~1e-4 s), e the law's
    e = restitution_of_hysteresis(fm.FloresLaw(K_STEEL, 0.8).chi)
    expected = int(np.sum(t1 + np.cumsum([0.0] + [2 * e ** k * G_ACC * t1 / G_ACC for k in range(1, 12)]) < 1.2))
    assert expected == 5
    assert res.n_contact_onsets == len(onsets) == expected and res.n_contact_separations == len(separations) == 5
    kinds = [e[2] for e in res.contact_events]
    assert kinds == ["onset", "separation"] * expected
    flight = onsets[1:, 0] - separations[:-1, 0]
    v_sep = -separations[:-1, 1]
    assert np.allclose(flight, 2 * v_sep / G_ACC, rtol=FLIGHT_TOL[method], atol=0)
    assert np.allclose(onsets[1:, 1], v_sep, rtol=FLIGHT_TOL[method])
    _report(f"drop {method}", first_impact_error=onsets[0, 0] - t1,
            flight_error=float(np.max(np.abs(flight / (2 * v_sep / G_ACC) - 1))), steps=res.n_steps)


@pytest.mark.parametrize("method", ["DOP853", "CVODE_BDF"])
def test_hertz_contact_time_closed_form(method):
    """No gravity, Hertz's undamped law: onset at gap/v, separation t_c later at the speed v."""
    v, gap = 1.0, 1e-3
    law = fm.HuntCrossleyLaw(K_STEEL, 0.0)
    d_max = (5 * M * v ** 2 / (4 * K_STEEL)) ** 0.4
    integral = quad(lambda x: 1 / np.sqrt(1 - x ** 2.5), 0, 1, limit=200)[0]
    t_c = 2 * integral * d_max / v
    res = fm.simulate(_drop_model(law, gravity=False), gap / v + 3 * t_c, x0=[R + gap], xd0=[-v], method=method,
                      rtol=1e-11, atol=1e-11 * d_max, progress=False, n_out=5)
    (t_on, rate_on), = _events(res, "onset")
    (t_off, rate_off), = _events(res, "separation")
    assert t_on == pytest.approx(gap / v, rel=1e-10)
    assert rate_on == pytest.approx(v, rel=1e-10)
    assert t_off - t_on == pytest.approx(t_c, rel=1e-7)
    assert -rate_off == pytest.approx(v, rel=1e-7)
    _report(f"Hertz contact time {method}", t_c=t_c, error=(t_off - t_on) / t_c - 1)


@pytest.mark.parametrize("law", [fm.LankaraniNikraveshLaw(K_STEEL, 0.9), fm.FloresLaw(K_STEEL, 0.5)])
def test_rebound_ratio_unchanged_by_events(law):
    """The rebound ratio is the law's with and without the events, and the events' own rates give it too."""
    v, gap = 2.0, 1e-3
    kw = dict(x0=[R + gap], xd0=[-v], method="DOP853", rtol=1e-10, atol=1e-14, progress=False, n_out=5)
    span = gap / v + 2e-3
    ref = restitution_of_hysteresis(law.chi)
    with_events = fm.simulate(_drop_model(law, gravity=False), span, **kw)
    without = fm.simulate(_drop_model(law, gravity=False), span, contact_events=False, max_step=2e-5, **kw)
    assert with_events.contact_events and not without.contact_events
    e_events = -_events(with_events, "separation")[0, 1] / _events(with_events, "onset")[0, 1]
    assert e_events == pytest.approx(ref, rel=1e-7)
    assert with_events.xd[-1, 0] / v == pytest.approx(ref, rel=1e-7)
    assert without.xd[-1, 0] / v == pytest.approx(with_events.xd[-1, 0] / v, rel=1e-7)
    assert with_events.n_steps < without.n_steps


def _bullet(offset):
    """A 1 g point flying along x at 50 m/s towards a fixed sphere of 20 mm at 1 m, ``offset`` off its centre."""
    model = fm.Model()
    bullet = fm.RigidBody("bullet", mass=1e-3, inertia=np.eye(3) * 1e-9)
    target = fm.SphereSphereContact("target", bullet, 0.0, model.ground, 0.02, fm.LinearContactLaw(1.0),
                                    centre2=(1.0, offset, 0))
    return model.add(fm.Prismatic("fly", model.ground, bullet, axis=(1, 0, 0)), target)


BULLET = dict(x0=[0.0], xd0=[50.0], method="DOP853", rtol=1e-8, progress=False, n_out=3)


def test_a_crossing_between_two_steps_is_found():
    """A point flying through a fixed sphere within one free-flight step: both ends apart, touched in between.

    The point crosses the sphere along a chord 12 mm off its centre, half
    its length 16 mm; a weak law (1 N/m) hardly slows it: it touches at
    (1 - 0.016) / 50 s and leaves at (1 + 0.016) / 50 s.
    """
    missed = fm.simulate(_bullet(0.012), 0.1, contact_events=False, **BULLET)
    assert missed.n_steps < 10  # free flight: steps as long as the span allows, through the sphere
    res = fm.simulate(_bullet(0.012), 0.1, **BULLET)
    assert [e[2] for e in res.contact_events] == ["onset", "separation"]
    ((t_on, _),), ((t_off, _),) = _events(res, "onset"), _events(res, "separation")
    assert t_on == pytest.approx((1 - 0.016) / 50, rel=1e-10)
    assert t_off == pytest.approx((1 + 0.016) / 50, rel=1e-6)


def test_tunnelling_is_refused_and_a_law_too_soft_fails_naming_the_contact():
    """The point aimed at the sphere's centre: its contact normal reverses there, and the weak law cannot stop it.

    Without events the run steps through the sphere and finishes as if
    nothing were there; with them, the steps that carry the point past the
    centre are refused, ever shorter, and the run fails naming the contact.
    """
    through = fm.simulate(_bullet(0.0), 0.1, contact_events=False, **BULLET)
    assert through.status == "finished" and through.x[-1, 0] > 1.02
    with pytest.raises(fm.SimulationError, match="contact 'target': its normal reversed") as info:
        fm.simulate(_bullet(0.0), 0.1, **BULLET)
    res = info.value.result
    assert res.n_refused > 10 and res.n_contact_onsets == 1


def test_stiff_contact_notice_names_the_remedy():
    """A ball resting on a stiff floor under an explicit method: thousands of tiny steps in contact; warned once."""
    law = fm.LinearContactLaw(1e12, 2e6)  # critically damped at 1e6 rad/s: DOP853 is held to steps of ~6e-6 s
    rest = R - M * G_ACC / 1e12
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = fm.simulate(_drop_model(law), 0.1, x0=[rest], xd0=[0.0], method="DOP853", rtol=1e-6,
                          progress=False, n_out=3)
    notes = [w for w in caught if issubclass(w.category, fm.StiffnessWarning) and "contact" in str(w.message)]
    assert len(notes) == 1
    text = str(notes[0].message)
    assert "'floor'" in text and "CVODE_BDF" in text and "soften" in text
    assert res.status == "finished" and res.n_steps > 2000
    with warnings.catch_warnings():  # an implicit method steps over the resting contact: no notice
        warnings.simplefilter("error", fm.StiffnessWarning)
        quiet = fm.simulate(_drop_model(law), 0.1, x0=[rest], xd0=[0.0], method="CVODE_BDF", rtol=1e-6,
                            progress=False, n_out=3)
    assert quiet.n_steps < 2000


def test_events_saved_and_loaded(tmp_path):
    res = fm.simulate(_drop_model(fm.FloresLaw(K_STEEL, 0.8)), 0.3, x0=[R + H], xd0=[0.0], method="DOP853",
                      progress=False, n_out=3)
    res.save(tmp_path / "drop.npz")
    back = fm.Result.load(tmp_path / "drop.npz")
    assert back.contact_events == res.contact_events and back.n_contact_onsets == 1


def test_impact_speeds_held_by_one_row_contacts_during_the_run_only():
    """A contact of one row holds the onset's rate (the kernels read it); a capsule on a plane (two rows) none.

    After the run nothing is held: an evaluation of the system outside a
    run takes the impact speed from the state (the laws' fallback).
    """
    from flexmb.impact_speeds import HeldSpeeds
    from flexmb.kernels.loads import LoadTables
    from flexmb.kernels.packing import N_TREE

    law = fm.FloresLaw(K_STEEL, 0.8)
    model = _drop_model(law)
    ball = model.element("ball")
    model.add(fm.CapsulePlaneContact("rod", ball, 0.01, [[0, 0, 0.5], [0, 0, 0.6]], law))  # far above the floor
    system = model.build()
    held = HeldSpeeds.of(system)
    assert list(held.rows) == ["floor"] and held.values.shape == (3,)
    seen = []
    original = held.hold

    def column():  # column 4 of contact_par in the packed tables the compiled right-hand side reads
        floats, _, _, index = system._packed
        k = N_TREE + LoadTables._fields.index("contact_par")
        return floats[index[k, 0]: index[k, 0] + index[k, 1] * index[k, 2]].reshape(index[k, 1], index[k, 2])[:, 4]

    def spy(name, speed):
        original(name, speed)
        seen.append((name, speed, column()[held.rows[name]]))

    held.hold = spy
    res = fm.simulate(system, 0.25, x0=[R + H], xd0=[0.0], method="DOP853", rtol=1e-10, progress=False, n_out=3)
    (t_on, _, _, v_in), = [e for e in res.contact_events if e[2] == "onset"]
    assert seen == [("floor", v_in, v_in)]
    assert not held.values.any() and not column().any()
