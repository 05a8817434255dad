"""Benchmark scenes of BENCHMARKS.md, built with flexmb's public API."""

from __future__ import annotations

import numpy as np

import flexmb as fm

B1_L, B1_B, B1_H = 1.0, 0.02, 0.005
B1_BETA = 7.7398e-4  # 1 % of critical in the first bending mode


def b1_material():
    """Aluminium of B1: E = 70 GPa, nu = 0.33, rho = 2700 kg/m^3."""
    return fm.Material(70e9, 2700.0, 0.33, name="aluminium")


def b1(n_segments: int, gravity: bool = True, damped: bool = True) -> fm.Model:
    """B1: planar cantilever, bending in the x-z plane only (one coordinate per segment)."""
    model = fm.Model(f"B1 N={n_segments}")
    beam = fm.FlexibleBody("beam", B1_L, fm.Section.rectangular(B1_B, B1_H), b1_material(), n_segments,
                           keep=("bend_y",), damping=B1_BETA if damped else 0.0)
    model.add(fm.Fixed("clamp", model.ground, beam))
    if gravity:
        model.add(fm.Gravity((0.0, 0.0, -9.81)))
    return model


def b1_reference():
    """Closed forms: Euler-Bernoulli static tip deflection (m) and f1..f3 (Hz)."""
    mat, sec = b1_material(), fm.Section.rectangular(B1_B, B1_H)
    EI, rhoA = mat.E * sec.Iy, mat.density * sec.area
    static = rhoA * 9.81 * B1_L**4 / (8 * EI)
    beta_l = np.array([1.8751041, 4.6940911, 7.8547574])
    freqs = beta_l**2 / (2 * np.pi) * np.sqrt(EI / (rhoA * B1_L**4))
    return static, freqs


def b2(n_segments: int, damped: bool = True) -> fm.Model:
    """B2: the B1 beam with torsion and both bendings, a 0.05 kg tip mass at (L, 0.02, 0), tilted gravity."""
    model = fm.Model(f"B2 N={n_segments}")
    beam = fm.FlexibleBody("beam", B1_L, fm.Section.rectangular(B1_B, B1_H), b1_material(), n_segments,
                           keep=("torsion", "bend_y", "bend_z"), damping=B1_BETA if damped else 0.0)
    tip = fm.RigidBody("tip", 0.05, (0.0, 0.0, 0.0), (0.0, 0.02, 0.0))
    model.add(fm.Fixed("clamp", model.ground, beam),
              fm.Fixed("tip_mount", beam, tip, parent_point=(B1_L, 0.0, 0.0)),
              fm.Gravity((0.0, -0.6 * 9.81, -0.8 * 9.81)))
    return model


B6_R, B6_L, B6_B, B6_H = 0.1, 0.4, 0.02, 0.005
B6_CRANK_MASS, B6_SLIDER_MASS = 0.5, 0.3
B6_SPEED = 2 * np.pi * 5.0  # 5 rev/s
B6_ZETA = 0.02  # damped variant: 2 % of critical in the rod's first bending mode


def b6_rod_frequency() -> float:
    """First in-plane bending frequency of the B6 rod, Hz: Euler-Bernoulli, pinned at both ends.

    In the mechanism both rod ends are held transversally (the crank tip is
    driven, the slider runs on its rail), so the first bending mode is the
    pinned-pinned one, f1 = (pi / L)^2 sqrt(E I_z / (rho A)) / (2 pi).
    """
    mat, sec = fm.Material.steel(), fm.Section.rectangular(B6_B, B6_H)
    return (np.pi / B6_L) ** 2 * np.sqrt(mat.E * sec.Iz / (mat.density * sec.area)) / (2 * np.pi)


def b6(damped: bool = False, n_segments: int = 8):
    """B6: planar slider-crank with a flexible steel rod, crank driven at 5 rev/s from rest, no gravity.

    Crank: slender bar r = 0.1 m, 0.5 kg, pinned to the ground at the origin
    about z. Rod: steel, L = 0.4 m, b = 0.02 m in the mechanism plane by
    h = 0.005 m, ``n_segments`` segments bending in the plane only
    (``bend_z``), pinned (not clamped) to the crank tip; its last end is
    pinned to the slider by the cut joint that closes the loop. Slider:
    0.3 kg block on a rail along x, starting at x = r + L. Damped variant:
    stiffness-proportional, 2 % of critical in the rod's first (pinned-pinned)
    bending mode.

    Returns
    -------
    model : Model
        The mechanism, with the driver ``"motor"`` on the crank pin.
    initial : dict
        Initial coordinates: everything straight, slider at r + L (the
        speeds are then made consistent with the driver by ``simulate``).
    """
    model = fm.Model(f"B6 {'damped' if damped else 'undamped'} N={n_segments}")
    crank = fm.RigidBody.slender_bar("crank", B6_CRANK_MASS, B6_R)
    rod = fm.FlexibleBody.uniform_beam("rod", B6_L, fm.Section.rectangular(B6_B, B6_H), fm.Material.steel(),
                                       n_segments, keep=("bend_z",), damping_ratio=B6_ZETA if damped else 0.0,
                                       frequency=b6_rod_frequency(), clamped=False)
    slider = fm.RigidBody.box("slider", B6_SLIDER_MASS, (0.04, 0.02, 0.02))
    pin = fm.Revolute("crank_pin", model.ground, crank)
    model.add(pin,
              fm.Revolute("rod_pin", crank, rod, parent_point=(B6_R, 0.0, 0.0)),
              fm.Prismatic("rail", model.ground, slider, axis=(1.0, 0.0, 0.0)),
              fm.PlanarRevolute("slider_pin", rod, slider, parent_point=(B6_L, 0.0, 0.0), cut=True),
              fm.Driver.constant_speed("motor", pin, speed=B6_SPEED))
    return model, {"rail": B6_R + B6_L}


def b6_midspan_deflection(res) -> np.ndarray:
    """Rod mid-span deflection from its chord (signed, in the plane), m, shape (nt,).

    The centre line's point at L / 2 (a segment end when N is even) minus
    its projection on the chord from the rod's first end to its last.
    """
    ends = res.shape("rod")
    a, b = ends[:, 0, :2], ends[:, -1, :2]
    n_seg = ends.shape[1] - 1
    if n_seg % 2 == 0:
        mid = ends[:, n_seg // 2, :2]
    else:
        mid = 0.5 * (ends[:, n_seg // 2, :2] + ends[:, n_seg // 2 + 1, :2])
    chord = b - a
    e = chord / np.linalg.norm(chord, axis=1)[:, None]
    d = mid - a
    return e[:, 0] * d[:, 1] - e[:, 1] * d[:, 0]


B7_L, B7_MASS, B7_G = 1.0, 1.0, 9.81
B7_SPEED = -1.0  # first rod's angular speed about +z, rad/s: its top moves at +1 m/s along +x


def b7(n_loops: int, planar_cuts: bool = True):
    """B7: a chain of ``n_loops`` parallelogram four-bars (IFToMM benchmark A02 for N = 1), under gravity.

    N + 1 uniform rods, 1 m and 1 kg (slender bars along their body y
    axis, body frame at the bottom end), are pinned to the ground about z
    at (k, 0, 0), k = 0 ... N (joints ``"pin_k"``), and start vertical,
    pointing up along +y. N uniform couplers, 1 m and 1 kg (slender bars
    along their body x axis, body frame at the first end): coupler k is
    pinned to the top of rod k by a tree joint (``"hinge_k"``), and its
    other end to the top of rod k + 1 by the cut joint ``"cut_k"`` that
    closes loop k. Gravity 9.81 m/s^2 along -y.

    With every coordinate zero the rods are vertical and the couplers
    horizontal; the mechanism has one degree of freedom: every rod at the
    same angle, every coupler translating. It has n = 2N + 1 coordinates
    (``pin_k.angle``, ``hinge_k.angle``) and, with planar cuts, 2N
    independent constraint rows.

    Parameters
    ----------
    n_loops : int
        Number of four-bar loops N (>= 1).
    planar_cuts : bool
        Close the loops with :class:`~flexmb.PlanarRevolute` cut joints
        (2 in-plane rows each, none redundant); if False with spatial
        :class:`~flexmb.Revolute` ones (5 rows each, of which 3 are
        redundant for this planar mechanism: 5N rows, rank 2N).

    Returns
    -------
    model : Model
        The chain.
    initial : dict
        Keyword arguments of :func:`flexmb.simulate` and
        :func:`flexmb.initial_state`: ``"positions"``, every coordinate 0
        (rods vertical, couplers horizontal, an assembled state), and
        ``"speeds"``, the first rod's angle rate -1 rad/s (its top moves at
        +1 m/s along +x; the other speeds follow from the constraints,
        ``pin_k`` -1 rad/s and ``hinge_k`` +1 rad/s). Use as
        ``fm.simulate(model, t_end, **initial)``.

    Raises
    ------
    ValueError
        If ``n_loops`` is not an integer >= 1.
    """
    if isinstance(n_loops, bool) or int(n_loops) != n_loops or n_loops < 1:
        raise ValueError(f"b7: n_loops must be an integer >= 1, got {n_loops!r}")
    n_loops = int(n_loops)
    model = fm.Model(f"B7 N={n_loops}{'' if planar_cuts else ' spatial cuts'}")
    cut = fm.PlanarRevolute if planar_cuts else fm.Revolute
    top = (0.0, B7_L, 0.0)
    rods = [fm.RigidBody.slender_bar(f"rod_{k}", B7_MASS, B7_L, axis=1) for k in range(n_loops + 1)]
    couplers = [fm.RigidBody.slender_bar(f"coupler_{k}", B7_MASS, B7_L) for k in range(n_loops)]
    for k, rod in enumerate(rods):
        model.add(fm.Revolute(f"pin_{k}", model.ground, rod, parent_point=(float(k), 0.0, 0.0)))
    for k, coupler in enumerate(couplers):
        model.add(fm.Revolute(f"hinge_{k}", rods[k], coupler, parent_point=top),
                  cut(f"cut_{k}", coupler, rods[k + 1], parent_point=(B7_L, 0.0, 0.0), child_point=top, cut=True))
    model.add(fm.Gravity((0.0, -B7_G, 0.0)))
    positions = {f"pin_{k}.angle": 0.0 for k in range(n_loops + 1)}
    positions.update({f"hinge_{k}.angle": 0.0 for k in range(n_loops)})
    return model, {"positions": positions, "speeds": {"pin_0.angle": B7_SPEED}}


def b7_tip(res) -> np.ndarray:
    """Position history of the first rod's top (the ``hinge_0`` point), m, shape (nt, 3).

    Parameters
    ----------
    res : Result
        A run of :func:`b7`.

    Returns
    -------
    ndarray, shape (nt, 3)
        Inertial positions of ``rod_0``'s top, m.
    """
    i = res.body_names.index("rod_0")
    return res.origins[:, i] + B7_L * res.rotations[:, i, :, 1]


def b7_reference(theta, n_loops: int) -> tuple[float, float]:
    """Closed form of the B7 parallelogram chain: its energies as a rate factor and a potential.

    With every rod at ``theta`` from the vertical (about +z) and the
    couplers translating, the kinetic energy is ``a theta'^2`` with
    ``a = (N + 1) (1/2)(m L^2 / 3) + N (1/2) m L^2`` and the potential
    (zero at y = 0) ``(N + 1) m g (L / 2) cos(theta) + N m g L cos(theta)``.

    Parameters
    ----------
    theta : float or ndarray
        Rod angle, rad.
    n_loops : int
        Number of loops N.

    Returns
    -------
    a : float
        Kinetic energy per theta'^2, kg m^2.
    potential : float or ndarray
        Potential energy, J.
    """
    m, L, g, n = B7_MASS, B7_L, B7_G, n_loops
    a = (n + 1) * 0.5 * m * L**2 / 3.0 + n * 0.5 * m * L**2
    return a, ((n + 1) * m * g * L / 2 + n * m * g * L) * np.cos(theta)


def b7_closed_form(t, n_loops: int) -> np.ndarray:
    """The first rod's top of B7 from the chain's own one-degree-of-freedom equation, m, shape (nt, 2).

    With every rod at ``theta`` and the couplers translating (the branch
    the chain keeps through its flat positions), Lagrange's equation of
    :func:`b7_reference`'s energies is ``2 a theta'' = P sin(theta)``,
    ``P = (N + 1) m g L / 2 + N m g L``, from ``theta = 0``,
    ``theta' = B7_SPEED``. It is integrated by scipy's DOP853 at rtol 1e-13
    (over 20 s the angle reaches about 63 rad: 1e-11 rad), independent of
    flexmb; the top is ``L (-sin theta, cos theta)``.

    Parameters
    ----------
    t : array_like, shape (nt,)
        Times, s, increasing from 0.
    n_loops : int
        Number of loops N.

    Returns
    -------
    ndarray, shape (nt, 2)
        x and y of ``rod_0``'s top, m.
    """
    from scipy.integrate import solve_ivp

    t = np.asarray(t, dtype=float)
    a, _ = b7_reference(0.0, n_loops)
    p = (n_loops + 1) * B7_MASS * B7_G * B7_L / 2 + n_loops * B7_MASS * B7_G * B7_L
    sol = solve_ivp(lambda _, y: [y[1], p * np.sin(y[0]) / (2 * a)], (0.0, float(t[-1])), [0.0, B7_SPEED],
                    method="DOP853", rtol=1e-13, atol=1e-14, t_eval=t)
    theta = sol.y[0]
    return B7_L * np.column_stack([-np.sin(theta), np.cos(theta)])
