"""Section loads, strains and stresses along flexible bodies; joint loads.

A flexible body is a chain of rigid segments joined by elastic segment
joints (section 2 of the paper, eqs. 21, 25-27). The load carried across
the section at a segment joint is the load of the joint's springs and
dampers on the coordinates the body keeps::

    M = k eta + c etadot            (c = beta k, eq. 5: F^s - F^d)

with k from :meth:`FlexibleBody.joint_stiffness` (2k at a clamped root).
From the section follow strains (curvature ``eta / l_j``), outer-fibre
stresses and a von Mises equivalent stress (see ``docs/stresses.md``).

The loads every joint transmits (tree joints, cut joints, segment joints)
come from the reaction recovery of :func:`joint_loads`: Newton-Euler on the
subtree each tree joint carries, with the constraint forces of the cut
joints (the multipliers of :meth:`System.reactions`) applied as body loads.

Sign convention, for both: the load is the one the outboard side (the
child, with everything it carries) exerts on the inboard side (the parent)
at the joint point; equivalently, minus the load the joint applies to the
child. For a cantilever bent down by a tip force P along -z this gives the
positive bending moment ``M_y = P (L - x)``, and positive ``M_y`` puts the
fibre at ``z = +c_z`` in tension.
"""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from ._names import name_of
from .errors import FlexmbError
from .flexible import FlexibleBody, segment_joint_class
from .joints import Joint
from .rotations import cross
from .kernels.dynamics import subtree_sums

__all__ = ["SectionField", "Envelope", "JointLoads", "LOAD_COMPONENTS", "section_loads", "section_strains",
           "section_stresses", "joint_loads", "constraint_loads", "joint_stations", "state_result"]

#: section-load component -> (kept elastic coordinate, unit)
LOAD_COMPONENTS = {"N": ("axial", "N"), "Vy": ("shear_y", "N"), "Vz": ("shear_z", "N"),
                   "Mx": ("torsion", "N m"), "My": ("bend_y", "N m"), "Mz": ("bend_z", "N m")}
_COORD_COMPONENT = {coord: comp for comp, (coord, _) in LOAD_COMPONENTS.items()}

#: strain component -> (kept elastic coordinate, unit)
STRAIN_COMPONENTS = {"strain_axial": ("axial", "1"), "twist": ("torsion", "rad/m"),
                     "kappa_y": ("bend_y", "1/m"), "kappa_z": ("bend_z", "1/m")}

#: stress components, all in Pa
STRESS_COMPONENTS = ("sigma_axial", "sigma_bend_y", "sigma_bend_z", "tau_torsion", "sigma_max", "von_mises")


@frozen(eq=False)
class Envelope:
    """Largest absolute value over time, per station and component.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    peak : ndarray, shape (n_stations, n_components)
        ``max_t |value|``.
    value : ndarray, shape (n_stations, n_components)
        The signed value at that time.
    time : ndarray, shape (n_stations, n_components)
        When it occurs (the first output time if several), s.
    index : ndarray of int, shape (n_stations, n_components)
        Output index of that time.
    stations : ndarray, shape (n_stations,)
        Station positions along the body, m.
    components : tuple of str
        Component names.
    """

    peak: np.ndarray
    value: np.ndarray
    time: np.ndarray
    index: np.ndarray
    stations: np.ndarray
    components: tuple

    def component(self, name: str) -> np.ndarray:
        """Peak of one component along the body.

        Parameters
        ----------
        name : str
            Component name.

        Returns
        -------
        ndarray, shape (n_stations,)
            ``max_t |value|`` at each station.
        """
        return self.peak[:, _component_index(self.components, name)]


def _component_index(components, name) -> int:
    try:
        return list(components).index(name)
    except ValueError:
        raise FlexmbError(f"no component {name!r}; components are {list(components)}") from None


@frozen(eq=False)
class SectionField:
    """A quantity along a flexible body over time: loads, strains or stresses.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    body : str
        Name of the flexible body.
    t : ndarray, shape (nt,)
        Output times, s.
    stations : ndarray, shape (n_stations,)
        Positions of the segment joints along the undeformed body (body
        frame x), m.
    components : tuple of str
        Component names (see :data:`LOAD_COMPONENTS`, :data:`STRAIN_COMPONENTS`,
        :data:`STRESS_COMPONENTS`).
    units : tuple of str
        Unit of each component.
    values : ndarray, shape (nt, n_stations, n_components)
        The values.
    """

    body: str
    t: np.ndarray
    stations: np.ndarray
    components: tuple
    units: tuple
    values: np.ndarray

    def component(self, name: str) -> np.ndarray:
        """History of one component at every station, shape (nt, n_stations).

        Parameters
        ----------
        name : str
            Component name.

        Returns
        -------
        ndarray, shape (nt, n_stations)
            Its values.

        Raises
        ------
        FlexmbError
            If there is no such component.
        """
        return self.values[:, :, _component_index(self.components, name)]

    def at(self, t) -> np.ndarray:
        """Values at given times, linearly interpolated between output times.

        Parameters
        ----------
        t : float or array_like, shape (m,)
            Times within ``[t[0], t[-1]]``, s.

        Returns
        -------
        ndarray, shape (n_stations, n_components) or (m, n_stations, n_components)
            The values (exact at the output times).

        Raises
        ------
        FlexmbError
            If a time is outside the result.
        """
        tq = np.asarray(t, dtype=float)
        _check_times(self.t, tq)
        if len(self.t) == 1:
            return np.broadcast_to(self.values[0], tq.shape + self.values.shape[1:]).copy()
        i = np.clip(np.searchsorted(self.t, tq, side="right") - 1, 0, len(self.t) - 2)
        w = ((tq - self.t[i]) / (self.t[i + 1] - self.t[i]))[..., None, None]
        return (1.0 - w) * self.values[i] + w * self.values[i + 1]

    def envelope(self) -> Envelope:
        """Largest absolute value over time at each station, and when it occurs.

        Returns
        -------
        Envelope
            Peaks, signed values, times and output indices, per station and
            component.
        """
        i = np.argmax(np.abs(self.values), axis=0)
        value = np.take_along_axis(self.values, i[None], axis=0)[0]
        return Envelope(np.abs(value), value, self.t[i], i, self.stations, self.components)


@frozen(eq=False)
class JointLoads:
    """Force and moment transmitted by every joint over time.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    t : ndarray, shape (nt,)
        Output times, s.
    names : list of str
        Joint names: the tree joints (user joints and segment joints
        ``"<body>.j<i>"``) in body order, then the cut joints.
    force : ndarray, shape (nt, n_joints, 3)
        Force the child side exerts on the parent side, N, in the joint's
        child marker frame (``R_child @ child_frame``; for a segment joint,
        the outboard segment's frame).
    moment : ndarray, shape (nt, n_joints, 3)
        Moment the child side exerts on the parent side about the joint
        point (the child's joint point), N m, same frame.
    """

    t: np.ndarray
    names: list
    force: np.ndarray
    moment: np.ndarray

    def joint(self, name) -> tuple[np.ndarray, np.ndarray]:
        """Force and moment histories of one joint, each shape (nt, 3).

        Parameters
        ----------
        name : str or Joint
            The joint or its name.

        Returns
        -------
        force, moment : ndarray, shape (nt, 3)
            N and N m, in the joint's child marker frame.

        Raises
        ------
        FlexmbError
            If there is no such joint.
        """
        name = name_of(name, Joint, "JointLoads.joint")
        try:
            i = self.names.index(name)
        except ValueError:
            raise FlexmbError(f"no joint {name!r}; joints are {self.names}") from None
        return self.force[:, i], self.moment[:, i]


def _check_times(t, tq):
    if tq.size and (np.any(~np.isfinite(tq)) or tq.min() < t[0] or tq.max() > t[-1]):
        bad = tq[(tq < t[0]) | (tq > t[-1]) | ~np.isfinite(tq)].ravel()
        raise FlexmbError(f"time {float(bad[0])!r} s is outside the result, which covers [{t[0]:.9g}, {t[-1]:.9g}] s")


def _resolve(result, body, system=None) -> FlexibleBody:
    """The FlexibleBody named or given, checked against the result."""
    flexible = sorted(result.flexible)
    if isinstance(body, str):
        system = system if system is not None else getattr(result, "system", None)  # to look the name up
        if system is not None:
            topo = getattr(system, "topology", None)
            if topo is None:  # a Model
                topo = system.build().topology
            found = [b for b in topo.flexible if b.name == body]
            if found:
                body = found[0]
        if isinstance(body, str):
            if body in result.flexible:
                raise FlexmbError(f"{body!r}: pass the FlexibleBody itself, or system=, to compute its section "
                                  "loads (a loaded Result keeps no section and material data)")
            raise FlexmbError(f"{body!r} is not a flexible body of the result; flexible bodies: {flexible}")
    if not isinstance(body, FlexibleBody):
        raise FlexmbError(f"{getattr(body, 'name', body)!r} is not a flexible body "
                          f"({type(body).__name__}); flexible bodies: {flexible}")
    if body.name not in result.flexible:
        raise FlexmbError(f"{body.name!r} is not a flexible body of the result; flexible bodies: {flexible}")
    return body


def joint_stations(body: FlexibleBody) -> np.ndarray:
    """Positions of a flexible body's segment joints along it, m.

    Parameters
    ----------
    body : FlexibleBody
        The body.

    Returns
    -------
    ndarray, shape (n_joints,)
        ``i l`` for the joints ``j<i>``: from 0 (a clamped root) or ``l``
        (a free root) to ``L - l``.
    """
    first = 0 if body.clamped else 1
    return body.segment_length * np.arange(first, body.n_segments)


def _lumped_length(body: FlexibleBody) -> np.ndarray:
    """Length of beam each joint lumps: l, and l / 2 at a clamped root (its spring is 2k)."""
    lj = np.full(body.n_joints, body.segment_length)
    if body.clamped:
        lj[0] *= 0.5
    return lj


def _columns(result, body: FlexibleBody):
    """Columns of x holding the body's elastic coordinates, shape (n_joints, n_keep), and their names."""
    names = segment_joint_class(body.keep).coordinate_names
    first = 0 if body.clamped else 1
    lookup = {c: i for i, c in enumerate(result.coordinate_names)}
    wanted = [[f"{body.name}.j{i}.{c}" for c in names] for i in range(first, body.n_segments)]
    missing = [w for row in wanted for w in row if w not in lookup]
    if missing:
        raise FlexmbError(f"flexible body {body.name!r} does not match the result: no coordinate(s) "
                          f"{missing[:3]} (a different model?)")
    return np.array([[lookup[w] for w in row] for row in wanted], dtype=int), names


def _field(result, body, components, units, values) -> SectionField:
    return SectionField(body.name, np.asarray(result.t, dtype=float), joint_stations(body), tuple(components),
                        tuple(units), values)


def section_loads(result, body, system=None) -> SectionField:
    """Internal loads at every segment joint of a flexible body, at every output time.

    Parameters
    ----------
    result : Result
        A simulation result.
    body : FlexibleBody or str
        The body, or its name (looked up in ``system``, else in the system
        the result came from, ``result.system``).
    system : System or Model, optional
        The model the result came from. Without it, only the components the
        body keeps are returned (from its springs and dampers); with it, all
        six, those the body does not keep from :func:`joint_loads`.

    Returns
    -------
    SectionField
        Components among ``N`` (axial force), ``Vy``, ``Vz`` (shear forces),
        N, ``Mx`` (torsion), ``My``, ``Mz`` (bending moments), N m, in this
        order, at the stations of :func:`joint_stations`; shape
        (nt, n_joints, n_components).

    Raises
    ------
    FlexmbError
        If ``body`` is not a flexible body of the result.

    Notes
    -----
    A kept coordinate's load is its spring plus damper load
    ``k eta + c etadot`` (eqs. 21, 25-27, 5), with ``c = beta k``. For a
    rotation it is the moment about that coordinate's rotation axis (the
    inboard segment's axis turned by the angles before it in the sequence
    Rx Ry Rz; exactly the outboard segment's axis when a single angle is
    kept, and to first order in any case), which is the section moment
    about that axis. For a translation it is the force along the inboard
    segment's axis. A coordinate the body does not keep is rigid: its load
    is a constraint reaction, not a spring load; it is recovered by
    :func:`joint_loads` (Newton-Euler on the outboard segments, in the
    outboard segment's frame) when ``system`` is given.

    Sign: the load the outboard part exerts on the inboard part; a
    cantilever bent down (-z) by a tip force P has ``My = P (L - x)``.

    Examples
    --------
    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005),
    ...                        fm.Material.aluminium(), 4, keep=("bend_y",))
    >>> _ = m.add(fm.Fixed("clamp", m.ground, beam), fm.Gravity((0, 0, -9.81)))
    >>> res = fm.simulate(m, 0.01, n_out=3)
    >>> section_loads(res, beam).values.shape
    (3, 4, 1)
    """
    body = _resolve(result, body, system)
    return _section_loads(result, body, None if system is None else joint_loads(result, system))


def _section_loads(result, body, jl) -> SectionField:
    """Section loads of a resolved body; with joint loads ``jl``, all six components."""
    cols, names = _columns(result, body)
    k = body.joint_stiffness()
    x = np.asarray(result.x, dtype=float)[:, cols]
    xd = np.asarray(result.xd, dtype=float)[:, cols]
    kept = k * x + body.damping * k * xd  # (nt, n_joints, n_keep)
    comps = [_COORD_COMPONENT[c] for c in names]
    if jl is None:
        return _field(result, body, comps, [LOAD_COMPONENTS[c][1] for c in comps], kept)
    first = 0 if body.clamped else 1
    rows = [jl.names.index(f"{body.name}.j{i}") for i in range(first, body.n_segments)]
    full = np.concatenate([jl.force[:, rows], jl.moment[:, rows]], axis=2)
    order = list(LOAD_COMPONENTS)
    full[:, :, [order.index(c) for c in comps]] = kept
    return _field(result, body, order, [LOAD_COMPONENTS[c][1] for c in order], full)


def section_strains(result, body, system=None) -> SectionField:
    """Strains at the segment joints: curvatures, twist rate and axial strain.

    Parameters
    ----------
    result : Result
        A simulation result.
    body : FlexibleBody or str
        The body, or its name (looked up in ``system``, else in the system
        the result came from, ``result.system``).
    system : System or Model, optional
        Only to look a body up by name.

    Returns
    -------
    SectionField
        Components among ``strain_axial`` (``u / l_j``), ``twist``
        (``eta_1 / l_j``, rad/m), ``kappa_y`` (``eta_2 / l_j``) and
        ``kappa_z`` (``eta_3 / l_j``, 1/m) for the kept coordinates, where
        ``l_j`` is the length of beam the joint lumps: l, or l / 2 at a
        clamped root (whose spring is 2k). Then ``M = E I kappa``,
        ``T = G J twist`` and ``N = E A strain_axial`` hold joint by joint.
        Shear coordinates have no strain component.

    Raises
    ------
    FlexmbError
        If ``body`` is not a flexible body of the result.
    """
    body = _resolve(result, body, system)
    cols, names = _columns(result, body)
    keep = [i for i, c in enumerate(names) if not c.startswith("shear")]
    comps = [s for s, (c, _) in STRAIN_COMPONENTS.items() if c in names]
    values = np.asarray(result.x, dtype=float)[:, cols[:, keep]] / _lumped_length(body)[None, :, None]
    return _field(result, body, comps, [STRAIN_COMPONENTS[c][1] for c in comps], values)


def section_stresses(result, body, system=None) -> SectionField:
    """Outer-fibre stresses and the von Mises equivalent stress at the segment joints.

    Parameters
    ----------
    result : Result
        A simulation result.
    body : FlexibleBody or str
        The body, or its name (looked up in ``system``, else in the system
        the result came from, ``result.system``).
    system : System or Model, optional
        With it the section loads include the components the body does not
        keep (see :func:`section_loads`); without it those contribute 0.

    Returns
    -------
    SectionField
        Components (Pa), shape (nt, n_joints, 6):

        * ``sigma_axial = N / A``;
        * ``sigma_bend_y = My c_z / I_y``: bending stress at the fibre
          ``z = +c_z`` (tension positive);
        * ``sigma_bend_z = Mz c_y / I_z``: at the fibre ``y = -c_y``;
        * ``tau_torsion = Mx / W_t``: the largest torsional shear stress,
          see :meth:`Section.torsion_modulus` (circle ``T r / J``, tube
          ``T r_o / J``, rectangle ``T / (alpha w t^2)``, Roark);
        * ``sigma_max``: largest normal stress magnitude in the section,
          ``|N/A| + |My| c_z/I_y + |Mz| c_y/I_z`` (rectangle and general:
          a corner), ``|N/A| + sqrt(My^2 + Mz^2) c / I`` (circle, tube);
        * ``von_mises = sqrt(sigma_max^2 + 3 tau_torsion^2)``.

    Raises
    ------
    FlexmbError
        If ``body`` is not a flexible body of the result, or its section
        has no outer-fibre distances.

    Notes
    -----
    Beam theory: ``sigma(y, z) = N/A + My z / I_y - Mz y / I_z``. The von
    Mises stress combines the largest normal stress with the largest
    torsional shear stress; for circles and tubes they occur at the same
    point, for a rectangle it is an upper bound. Transverse shear stresses
    from ``Vy``, ``Vz`` (largest at the neutral axis, zero at the outer
    fibres) are left out.
    """
    body = _resolve(result, body, system)
    return _stresses(result, body, section_loads(result, body, system))


def _stresses(result, body, loads) -> SectionField:
    """Stresses from the section loads of a resolved body."""
    s = body.section
    if body.profile is not None:
        raise FlexmbError(f"flexible body {body.name!r}: its section varies along it (a BeamProfile); stresses "
                          "use one section per body and are not available for it (section loads are)")
    if s.c_y <= 0 or s.c_z <= 0:
        raise FlexmbError(f"flexible body {body.name!r}: its section {s.name!r} has no outer-fibre distances "
                          f"(c_y = {s.c_y}, c_z = {s.c_z}); give them to compute stresses")
    nt, ns = loads.values.shape[:2]

    def load(name):
        return loads.component(name) if name in loads.components else np.zeros((nt, ns))

    sig_n = load("N") / s.area
    sig_y = load("My") * s.c_z / s.Iy
    sig_z = load("Mz") * s.c_y / s.Iz
    tau = load("Mx") / s.torsion_modulus()
    if s.kind in ("circular", "tube"):
        bend = np.hypot(load("My"), load("Mz")) * s.c_y / s.Iy
    else:
        bend = np.abs(sig_y) + np.abs(sig_z)
    sig_max = np.abs(sig_n) + bend
    vm = np.sqrt(sig_max**2 + 3.0 * tau**2)
    values = np.stack([sig_n, sig_y, sig_z, tau, sig_max, vm], axis=2)
    return _field(result, body, STRESS_COMPONENTS, ("Pa",) * len(STRESS_COMPONENTS), values)


# -- reaction recovery


def _cut_rows(system):
    """For the constraint blocks (points, directions, perpendiculars): the cut joint of each entry."""
    pts, drs, pps = [], [], []
    for c, j in enumerate(system.topology.cut_joints):
        if j.cut_point:
            pts.append(c)
        drs += [c] * len(j.cut_directions)
        pps += [c] * len(j.cut_perpendicular)
    return np.array(pts, dtype=int), np.array(drs, dtype=int), np.array(pps, dtype=int)


def constraint_loads(system, kin, lam):
    """Body forces and torques equivalent to the cut joints' constraint forces.

    ``psi^T lambda`` (eq. 29) written as loads on bodies: a point row pair
    pushes the parent with ``lambda`` at its point and the child with
    ``-lambda``; a direction row adds ``lambda d`` at the child's point,
    ``-lambda d`` and the torque ``lambda d x e`` on the parent; a
    perpendicularity row twists the parent by ``lambda a x b`` and the child
    by the opposite. Driver rows act on coordinates and are left out.

    Parameters
    ----------
    system : System
        The compiled model.
    kin : Kinematics
        The state.
    lam : ndarray, shape (m,)
        Constraint multipliers (:meth:`System.reactions`).

    Returns
    -------
    force, torque : ndarray, shape (n_bodies + 1, 3)
        Resultant force at each mass centre and torque about it (inertial;
        the last row is the ground).
    cut_force, cut_moment : ndarray, shape (n_cut, 3)
        Load each cut joint's child exerts on its parent, inertial, the
        moment about the parent's joint point.
    """
    from .forces import Loads

    cons = system.constraints
    loads = Loads(kin)
    ncut = len(system.topology.cut_joints)
    cf, cm = np.zeros((ncut, 3)), np.zeros((ncut, 3))
    jp, jd, jq = _cut_rows(system)
    row = 0
    ri, pi, rj, pj = cons.pt
    if len(ri):
        lp = lam[row : row + 3 * len(ri)].reshape(-1, 3)
        row += 3 * len(ri)
        Pi, Pj = kin.point_position(ri, pi), kin.point_position(rj, pj)
        loads.add_point_force(ri, Pi, lp)
        loads.add_point_force(rj, Pj, -lp)
        np.add.at(cf, jp, lp)
    ri, pi, ai, rj, pj = cons.dr
    if len(ri):
        ld = lam[row : row + len(ri)]
        row += len(ri)
        Pi, Pj = kin.point_position(ri, pi), kin.point_position(rj, pj)
        d = np.einsum("mij,mj->mi", kin.R[ri], ai)
        tq = ld[:, None] * cross(d, Pj - Pi)
        loads.add_point_force(rj, Pj, ld[:, None] * d)
        loads.add_point_force(ri, Pi, -ld[:, None] * d)
        loads.add_torque(ri, tq)
        np.add.at(cf, jd, -ld[:, None] * d)
        np.add.at(cm, jd, tq)
    ri, ai, rj, bj = cons.pp
    if len(ri):
        lq = lam[row : row + len(ri)]
        a = np.einsum("mij,mj->mi", kin.R[ri], ai)
        b = np.einsum("mij,mj->mi", kin.R[rj], bj)
        tq = lq[:, None] * cross(a, b)
        loads.add_torque(ri, tq)
        loads.add_torque(rj, -tq)
        np.add.at(cm, jq, tq)
    return loads.force, loads.torque, cf, cm


def _loads_at(system, t, x, xd, xdd, lam):
    """Joint loads at one state (inertial), tree joints then cut joints."""
    kin = system.kinematics(t, x, xd)
    topo = system.topology
    applied = system.forces.loads(kin)
    cforce, ctorque, cut_f, cut_m = constraint_loads(system, kin, lam)
    F = (applied.force + cforce)[:-1]
    tau = (applied.torque + ctorque)[:-1]
    a = kin.V[:-1] @ xdd + kin.a_bias[:-1]
    alpha = kin.W[:-1] @ xdd + kin.alpha_bias[:-1]
    I = kin.inertia_world()
    w = kin.omega[:-1]
    # Newton-Euler residual of each body: what its parent joint must supply
    D = kin.mass[:, None] * a - F
    H = np.einsum("kij,kj->ki", I, alpha) + cross(w, np.einsum("kij,kj->ki", I, w)) - tau
    r = kin.r[:-1]
    # what each subtree's bodies need, summed over the subtree
    f = subtree_sums(topo.parent, np.ascontiguousarray(D))
    m = subtree_sums(topo.parent, cross(r, D) + H) - cross(kin.joint_point, f)
    frames = kin.R[:-1] @ topo.child_frame
    # the child side exerts minus what the joint supplies to it
    force = -np.einsum("kji,kj->ki", frames, f)
    moment = -np.einsum("kji,kj->ki", frames, m)
    if topo.cut_joints:
        idx = topo.index
        rows = np.array([idx[j.child] for j in topo.cut_joints], dtype=int)
        fc = np.array([j.frames()[1] for j in topo.cut_joints]).reshape(-1, 3, 3)
        cfr = kin.R[rows] @ fc
        force = np.vstack([force, np.einsum("kji,kj->ki", cfr, cut_f)])
        moment = np.vstack([moment, np.einsum("kji,kj->ki", cfr, cut_m)])
    return force, moment


def joint_loads(result, system) -> JointLoads:
    """Force and moment transmitted by every joint, at every output time (reaction recovery).

    Parameters
    ----------
    result : Result
        A simulation result of ``system``.
    system : System or Model
        The model it came from.

    Returns
    -------
    JointLoads
        Per joint (tree joints in body order, then cut joints), the force
        and moment the child side exerts on the parent side at the joint,
        in the joint's child marker frame.

    Raises
    ------
    FlexmbError
        If the system does not match the result.

    Notes
    -----
    For the tree joint of body k, Newton-Euler on the subtree S_k it
    carries (eqs. 13, 18 for the accelerations ``a = V xdd + Vdot xd``,
    ``alpha = W xdd + Wdot xd``)::

        f_k = sum_{b in S_k} (m_b a_b - F_b)
        m_k = sum_{b in S_k} [(r_b - p_k) x (m_b a_b - F_b) + I_b alpha_b + w_b x I_b w_b - T_b]

    is what the joint supplies to the child; the tables hold ``-f_k``,
    ``-m_k``. F and T hold the applied loads and the cut joints'
    constraint forces (:func:`constraint_loads`). Generalized forces on
    coordinates (joint springs, segment springs, drivers) act inside a
    joint: inside the subtree they cancel, and on the joint itself they are
    part of what it transmits, so they need no term. For a segment joint
    the moment about a kept axis equals the spring plus damper moment of
    :func:`section_loads`. A cut joint's load is its constraint force on
    the parent, moment about the parent's joint point.
    """
    if not hasattr(system, "topology"):
        system = system.build()
    x = np.asarray(result.x, dtype=float)
    if x.shape[1] != system.n_coords or list(system.body_names) != list(result.body_names):
        raise FlexmbError("the system does not match the result: different bodies or number of coordinates")
    lam = np.asarray(result.reactions, dtype=float)
    if lam.shape != (len(result.t), system.n_constraints):
        raise FlexmbError(f"result.reactions has shape {lam.shape}, expected "
                          f"{(len(result.t), system.n_constraints)}")
    nt = len(result.t)
    nj = system.topology.n_bodies + len(system.topology.cut_joints)
    force = np.zeros((nt, nj, 3))
    moment = np.zeros((nt, nj, 3))
    for i in range(nt):  # one kinematics per output time; vectorised over bodies and joints
        force[i], moment[i] = _loads_at(system, result.t[i], x[i], result.xd[i], result.xdd[i], lam[i])
    names = [j.name for j in system.topology.tree_joints] + [j.name for j in system.topology.cut_joints]
    return JointLoads(np.asarray(result.t, dtype=float), names, force, moment)


def state_result(system, x, xd=None, *, xdd=None, t: float = 0.0):
    """A :class:`Result` holding given states, so that loads and stresses apply to statics too.

    Parameters
    ----------
    system : System or Model
        The model.
    x : array_like, shape (n,) or (m, n)
        Coordinates of one or m states (e.g. from :func:`flexmb.linear_statics`).
    xd : array_like, same shape, optional
        Speeds (default zero).
    xdd : array_like, same shape, optional
        Accelerations; default: from the equations of motion (eqs. 36-39).
        Pass zeros for the loads that hold a configuration in equilibrium.
    t : float
        Time of every state, s.

    Returns
    -------
    Result
        With ``t = [t, t + 1, ...]`` (one output per state), positions,
        rotations, accelerations and constraint multipliers filled in.
    """
    from .result import Result

    if not hasattr(system, "topology"):
        system = system.build()
    n = system.n_coords
    X = np.atleast_2d(np.asarray(x, dtype=float))
    XD = np.zeros_like(X) if xd is None else np.atleast_2d(np.asarray(xd, dtype=float))
    if X.shape[1] != n or XD.shape != X.shape:
        raise FlexmbError(f"x and xd must hold {n} coordinates per state, got shapes {X.shape}, {XD.shape}")
    nt = len(X)
    times = float(t) + np.arange(nt, dtype=float)
    XDD = (np.array([system.accelerations(t, a, b) for a, b in zip(X, XD)]) if xdd is None
           else np.atleast_2d(np.asarray(xdd, dtype=float)).reshape(X.shape))
    kins = [system.kinematics(t, a, b) for a, b in zip(X, XD)]
    lam = np.array([system.reactions(t, a, b, c) for a, b, c in zip(X, XD, XDD)]).reshape(nt, -1)
    topo = system.topology
    zeros = np.zeros(nt)
    return Result(
        t=times, x=X, xd=XD, xdd=XDD, positions=np.array([k.r[:-1] for k in kins]),
        origins=np.array([k.origin[:-1] for k in kins]), rotations=np.array([k.R[:-1] for k in kins]),
        kinetic=zeros, potential=zeros, residual=zeros, velocity_residual=zeros, reactions=lam,
        coordinate_names=list(system.coordinate_names), body_names=list(system.body_names),
        constraint_labels=list(system.constraints.labels),
        driver_names=[d.name for d in system.constraints.drivers],
        flexible={b.name: ([topo.index[sg] for sg in segs], b.segment_length)
                  for b, (_, segs, _) in topo.flexible.items()},
        status="finished", message="given states", system=system,
    )
