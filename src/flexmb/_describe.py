"""What a model is made of, in words: what ``flexmb info``, ``print(model)`` and ``repr(system)`` say.

One description serves them all: the bodies (with their masses and, for
flexible bodies, segments and kept coordinates), the joints (with their
coordinates, or the constraint rows of a joint that closes a loop), the force
elements and drivers, then the counts: coordinates n, constraint rows m, the
rank of the constraint Jacobian psi (at a scene's initial state; at a
generic state for a model or system, which have none), the redundant rows
m - rank and the degrees of freedom p = n - rank.
"""

from __future__ import annotations

import numpy as np

__all__ = []


#: where a model or system without an initial state takes the rank of psi
GENERIC = "a generic state (coordinates drawn at random, seed 0)"


def generic_state(system):
    """A state in no particular configuration (seeded random coordinates, zero speeds).

    The rank of psi there is its generic rank (the largest it takes), with
    probability 1: a model or system has no initial state, and all
    coordinates 0 is often a singular configuration (a four-bar folded flat)
    or one where the loops do not close.

    Returns
    -------
    x0, xd0 : ndarray
        The state.
    """
    x0 = system.layout.normalized(np.random.default_rng(0).uniform(-1.0, 1.0, system.n_coords))
    return x0, np.zeros(system.n_speeds)


def counts(system, x0, xd0) -> tuple[int, int, int]:
    """Constraint rows m, rank of psi at the state and degrees of freedom p = n - rank.

    Takes no more memory than a run: no rows, no matrix (an open tree of
    100,000 segments built an n x n identity); loops closed by the loop
    kernel, its O(n m) rank; otherwise the complement a run uses.
    """
    n, m = system.n_speeds, system.n_constraints
    if m == 0:
        return 0, 0, n
    if system._loop_kernel:
        rank, _ = system._loop_calibration(0.0, x0, xd0)
        return m, rank, n - rank
    kin = system.kinematics(0.0, x0, xd0)
    psi = system.constraints.evaluate(kin, level=1).psi
    c = system.strategy.complement(psi)
    return m, c.rank, c.p


def describe(system, x0, xd0, *, types=None, where="the initial state") -> list[str]:
    """The lines of the description of a built system at a state.

    Parameters
    ----------
    system : System
        The built model.
    x0, xd0 : ndarray
        The state at which the rank of psi is taken.
    types : dict of str to str, optional
        The name each element is known by (a scene's plugin names,
        ``rigid_body``, ``revolute``, ...), by its scene table
        (``"bodies.crank"``, ``"joints.A"``, ``"forces.gravity"``,
        ``"constraints.roll"``); default: the class names.
    where : str
        What the state is, for the rank's line.

    Returns
    -------
    list of str
        One line per body, joint, force list and driver, then the counts
        and the evaluation path (planar or spatial, with the reason).
    """
    from .flexible import FlexibleBody

    model, types = system.model, types or {}
    names = system.coordinate_names
    lines = [f"bodies ({len(model.bodies)}):"]
    for b in model.bodies:
        extra = ""
        if isinstance(b, FlexibleBody):
            extra = f", {b.n_segments} segments keeping {', '.join(b.keep)} ({b.n_elastic} elastic coordinates)"
        kind = types.get("bodies." + b.name, type(b).__name__)
        lines.append(f"  {b.name}: {kind}, mass {b.mass:.6g} kg{extra}")
    cuts = set(system.topology.cut_joints)
    lines.append(f"joints ({len(model.joints)}):")
    for j in model.joints:
        mine = [n for n in names if n.rsplit(".", 1)[0] == j.name]
        if j in cuts:
            rows = sum(1 for lab in system.constraints.labels if lab.split(".", 1)[0] == j.name)
            what = f"cut joint closing a loop, {rows} constraint rows"
        else:
            what = "coordinates " + (", ".join(mine) if mine else "none")
        kind = types.get("joints." + j.name, type(j).__name__)
        lines.append(f"  {j.name}: {kind} {j.parent.name} -> {j.child.name}; {what}")
    if model.forces:
        lines.append("forces: " + ", ".join(f"{f.name} ({types.get('forces.' + f.name, type(f).__name__)})"
                                            for f in model.forces))
    for e in model.constraints:
        kinds = [f"{k} {what} row{'s' if k > 1 else ''}" for k, what in ((e.n_position, "position"),
                                                                        (e.n_velocity, "velocity")) if k]
        kind = types.get("constraints." + e.name, type(e).__name__)
        lines.append(f"constraint {e.name}: {kind}, {' and '.join(kinds) or 'no rows'}")
    for d in model.drivers:
        lines.append(f"driver {d.name}: drives {names[system.coordinate_slice(d.joint).start + d.coordinate]}")
    m, rank, p = counts(system, x0, xd0)
    lines += [
        f"coordinates: n = {system.n_coords}",
        f"constraint rows: m = {m}" + (f" ({', '.join(system.constraints.labels)})" if 0 < m <= 12 else ""),
        f"rank of psi at {where}: {rank}; redundant rows: {m - rank}",
        f"degrees of freedom: p = n - rank = {p}"
        + (f" (drivers prescribe {len(model.drivers)})" if model.drivers else "")
        + (f" independent speeds ({system.constraints.n_velocity} velocity rows: the configuration has more "
           "freedoms than speeds)" if system.constraints.n_velocity else ""),
        "evaluation: " + ("planar (every joint moves in one plane: flexmb.kernels.planar)"
                          if getattr(system, "planar", False)
                          else f"spatial (not planar: {getattr(system, 'planar_reason', '') or 'not judged'})"),
    ]
    return lines


def one_line(system) -> str:
    """``System 'name': ... bodies, ... joints, n = ..., ... loops, m = ... (... redundant), p = ...``.

    Never raises (a repr): a count that cannot be had is left out.
    """
    model = system.model
    text = (f"System {model.name!r}: {len(model.bodies)} bodies, {len(model.joints)} joints, "
            f"n = {system.n_coords} coordinates, {len(system.topology.cut_joints)} loop-closing joints, "
            f"m = {system.n_constraints} constraint rows")
    try:
        m, rank, p = counts(system, *generic_state(system))
        text += f" ({m - rank} redundant), p = {p} degrees of freedom"
    except Exception:  # noqa: BLE001 - a repr must not fail
        pass
    strategy = getattr(system.strategy, "name", type(system.strategy).__name__)
    return f"<{text}; complement {strategy}>"
