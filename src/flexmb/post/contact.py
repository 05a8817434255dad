"""What the contact elements did: penetration, forces and slip at each output time of a result.

Computed from the stored states (positions and speeds) with the elements'
own compiled evaluation (:func:`flexmb.kernels.loads.contact_states`), so
that the history is what the integrator saw at those states.
"""

from __future__ import annotations

import numpy as np
from attrs import frozen

from ..errors import ModelError
from .motion import _system

__all__ = ["ContactHistory", "contact_history"]


@frozen
class ContactHistory:
    """What a contact element did at each output time of a result (:func:`contact_history`).

    Parameters
    ----------
    name : str
        The element's name.
    t : ndarray, shape (nt,)
        Output times, s.
    penetration : ndarray, shape (nt,)
        delta, m (negative: the gap while separated).
    penetration_rate : ndarray, shape (nt,)
        delta_dot, m/s (positive approaching).
    normal_force : ndarray, shape (nt,)
        N (0 while separated).
    force : ndarray, shape (nt, 3)
        Normal plus friction force on the first body (the sphere's), inertial, N.
    friction_force : ndarray, shape (nt, 3)
        Its tangential part, N.
    point : ndarray, shape (nt, 3)
        Contact point (the middle of the overlap), inertial, m.
    normal : ndarray, shape (nt, 3)
        Unit normal, towards the first body.
    slip : ndarray, shape (nt, 3)
        Tangential velocity of the first body's material point relative to
        the second's at the contact point, m/s.
    elastic_energy : ndarray, shape (nt,)
        Energy stored in the penetration, J.
    """

    name: str
    t: np.ndarray
    penetration: np.ndarray
    penetration_rate: np.ndarray
    normal_force: np.ndarray
    force: np.ndarray
    friction_force: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    slip: np.ndarray
    elastic_energy: np.ndarray

    @property
    def slip_speed(self) -> np.ndarray:
        """``|slip|``, m/s, shape (nt,)."""
        return np.linalg.norm(self.slip, axis=1)

    @property
    def in_contact(self) -> np.ndarray:
        """Whether the surfaces overlap (``penetration > 0``), shape (nt,)."""
        return self.penetration > 0


def contact_history(result, element, system=None) -> ContactHistory:
    """Penetration, forces and slip of a contact element at each output time of a result.

    Parameters
    ----------
    result : Result
        A simulation result.
    element : SpherePlaneContact, SphereSphereContact or str
        The contact element, or its name.
    system : System or Model, optional
        The model the result came from (default ``result.system``).

    Returns
    -------
    ContactHistory
        The penetration, forces, point, normal, slip and elastic energy at
        each output time.

    Raises
    ------
    ModelError
        If no system is known, or the element is not a contact element of it.

    Examples
    --------
    A ball resting on the floor (a linear contact law of 10^5 N/m): the
    floor carries its weight, 1 kg at 9.81 m/s^2, with 98.1 um of penetration.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> ball = fm.RigidBody("ball", mass=1.0, inertia=np.eye(3) * 1e-3)
    >>> floor = fm.SpherePlaneContact("floor", ball, 0.05, fm.LinearContactLaw(1e5, 100.0))
    >>> _ = model.add(fm.Prismatic("drop", model.ground, ball, axis=(0, 0, 1)), floor, fm.Gravity((0, 0, -9.81)))
    >>> res = fm.simulate(model, 0.5, x0=[0.05 - 9.81e-5], xd0=[0.0], progress=False, n_out=3)
    >>> h = res.contact_history("floor")
    >>> h.normal_force.round(9), (h.penetration * 1e6).round(3)
    (array([9.81, 9.81, 9.81]), array([98.1, 98.1, 98.1]))
    """
    from ..forces.contact import Contact

    system = _system(result, system, "contact_history")
    try:
        element = system.model.element(element)  # the model's copy, if it resolved names
    except ModelError as exc:
        raise ModelError(f"Result.contact_history: {exc}") from None
    if not isinstance(element, Contact):
        raise ModelError(f"Result.contact_history: {type(element).__name__} {element.name!r} is not a contact element")
    from ..impact_speeds import HeldSpeeds

    held = HeldSpeeds.of(system)
    nt = result.t.shape[0]
    out = {k: np.zeros(nt) for k in ("penetration", "penetration_rate", "normal_force", "elastic_energy")}
    out.update({k: np.zeros((nt, 3)) for k in ("force", "friction_force", "point", "normal", "slip")})
    for i in range(nt):
        kin = system.kinematics(result.t[i], result.x[i], result.xd[i])
        speeds = [held.at(result.contact_events, element.name, result.t[i])]  # held by a one-row contact only
        delta, rate, fn, energy, point, normal, force, slip = type(element).states_all([element], kin, speeds)
        out["penetration"][i], out["penetration_rate"][i] = delta[0], rate[0]
        out["normal_force"][i], out["elastic_energy"][i] = fn[0], energy[0]
        out["force"][i], out["point"][i], out["normal"][i], out["slip"][i] = force[0], point[0], normal[0], slip[0]
        out["friction_force"][i] = force[0] - fn[0] * normal[0]
    return ContactHistory(element.name, np.array(result.t, dtype=float), **out)
