"""Section loads, strains and stresses along flexible bodies.

A flexible body is a chain of rigid segments joined by elastic segment
joints (section 2 of the paper, eqs. 21, 25-27). The load carried across
the section at a segment joint is the load of the joint's springs and
dampers on the coordinates the body keeps::

    M = k eta + c etadot            (c = beta k, eq. 5: F^s - F^d)

with k from :meth:`FlexibleBody.joint_stiffness` (2k at a clamped root).
From the section follow strains (curvature ``eta / l_j``), outer-fibre
stresses and a von Mises equivalent stress (see ``docs/stresses.md``).
For a cantilever bent down by a tip force P along -z the convention of
:mod:`flexmb.post` gives the positive bending moment ``M_y = P (L - x)``,
and positive ``M_y`` puts the fibre at ``z = +c_z`` in tension.
"""

from __future__ import annotations

import numpy as np

from ..errors import FlexmbError
from ..flexible import FlexibleBody, segment_joint_class
from ..model import as_system
from .fields import _COORD_COMPONENT, LOAD_COMPONENTS, STRAIN_COMPONENTS, STRESS_COMPONENTS, SectionField
from .joint_loads import joint_loads

__all__ = ["section_loads", "section_strains", "section_stresses", "joint_stations"]


def _resolve(result, body, system=None) -> FlexibleBody:
    """The FlexibleBody named or given, checked against the result."""
    flexible = sorted(result.flexible)
    if isinstance(body, str):
        system = system if system is not None else getattr(result, "system", None)  # to look the name up
        if system is not None:
            topo = as_system(system).topology
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
