"""The post-processing a Result offers as methods (mixed into :class:`~flexmb.Result`).

Each method hands the result to the function of :mod:`flexmb.post` that
does the work; they are here so that result.py keeps to the time histories.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError

__all__ = ["ResultPost"]


class ResultPost:
    """Point and body motions, contact histories, section loads, strains and stresses, joint loads of a Result."""

    def point_position(self, body, point=(0.0, 0.0, 0.0), system=None) -> np.ndarray:
        """Position history of a point fixed in a body; see :func:`flexmb.post.motion.point_motion`.

        Parameters
        ----------
        body : Body or str
            The body (rigid or flexible), or its name.
        point : array_like, shape (3,)
            The point in the body's frame, m (default its origin).
        system : System or Model, optional
            The model the result came from (default :attr:`system`).

        Returns
        -------
        ndarray, shape (nt, 3)
            Inertial positions, m.
        """
        from .motion import point_motion

        return point_motion(self, body, point, 0, system)

    def point_velocity(self, body, point=(0.0, 0.0, 0.0), system=None) -> np.ndarray:
        """Velocity history of a point fixed in a body; see :func:`flexmb.post.motion.point_motion`.

        Parameters
        ----------
        body : Body or str
            The body (rigid or flexible), or its name.
        point : array_like, shape (3,)
            The point in the body's frame, m (default its origin).
        system : System or Model, optional
            The model the result came from (default :attr:`system`).

        Returns
        -------
        ndarray, shape (nt, 3)
            Inertial velocities, m/s.
        """
        from .motion import point_motion

        return point_motion(self, body, point, 1, system)

    def point_acceleration(self, body, point=(0.0, 0.0, 0.0), system=None) -> np.ndarray:
        """Acceleration history of a point fixed in a body; see :func:`flexmb.post.motion.point_motion`.

        Parameters
        ----------
        body : Body or str
            The body (rigid or flexible), or its name.
        point : array_like, shape (3,)
            The point in the body's frame, m (default its origin).
        system : System or Model, optional
            The model the result came from (default :attr:`system`).

        Returns
        -------
        ndarray, shape (nt, 3)
            Inertial accelerations, m/s^2 (from the stored ``xdd``).
        """
        from .motion import point_motion

        return point_motion(self, body, point, 2, system)

    def angular_velocity(self, body, frame: str = "inertial", point=(0.0, 0.0, 0.0), system=None) -> np.ndarray:
        """Angular velocity history of a body; see :func:`flexmb.post.motion.angular_velocity`.

        Parameters
        ----------
        body : Body or str
            The body, or its name.
        frame : {'inertial', 'body'}
            Components in inertial axes or in the body's frame.
        point : array_like, shape (3,)
            On a flexible body, a point of the segment meant (default the
            root segment).
        system : System or Model, optional
            The model the result came from (default :attr:`system`).

        Returns
        -------
        ndarray, shape (nt, 3)
            rad/s.
        """
        from .motion import angular_velocity

        return angular_velocity(self, body, frame, point, system)

    def body_rotation(self, body, view: str = "matrix") -> np.ndarray:
        """Rotation history of a body (body frame -> inertial), as a matrix, Bryant angles or axis-angle.

        Whatever a joint's coordinates (Bryant angles or Euler parameters),
        :attr:`rotations` holds each body's rotation matrix; this offers
        other views of it (:mod:`flexmb.quaternions`).

        Parameters
        ----------
        body : Body or str
            The body, or its name (a flexible body: its root segment).
        view : {'matrix', 'bryant', 'axis-angle', 'quaternion'}
            The matrix; the Bryant angles ``(rx, ry, rz)`` of ``Rx Ry Rz``
            (rad, singular at ry = +-90 deg); the rotation vector (axis
            times angle, rad); the unit quaternion ``(qx, qy, qz, qw)``,
            ``qw >= 0``.

        Returns
        -------
        ndarray, shape (nt, 3, 3), (nt, 3) or (nt, 4)
            The rotation at each output time.

        Raises
        ------
        ModelError
            If no body has that name, or the view is unknown.
        """
        from .. import quaternions
        from .._names import name_of
        from ..bodies import Body

        name = name_of(body, Body, "Result.body_rotation")
        if name in self.flexible:
            row = self.flexible[name][0][0]
        elif name in self.body_names:
            row = self.body_names.index(name)
        else:
            raise ModelError(f"Result.body_rotation: no body {name!r}; known: {self.body_names}")
        R = self.rotations[:, row]
        views = {"matrix": lambda: R.copy(), "bryant": lambda: quaternions.bryant_angles(R),
                 "axis-angle": lambda: quaternions.rotation_vector(R),
                 "quaternion": lambda: quaternions.from_rotation_matrix(R)}
        if view not in views:
            raise ModelError(f"Result.body_rotation: view must be one of {list(views)}, got {view!r}")
        return views[view]()

    def contact_history(self, element, system=None):
        """Penetration, forces and slip of a contact element; see :func:`flexmb.post.contact.contact_history`.

        Parameters
        ----------
        element : SpherePlaneContact, SphereSphereContact or str
            The contact element, or its name.
        system : System or Model, optional
            The model the result came from (default :attr:`system`).

        Returns
        -------
        ContactHistory
            The history at the output times.
        """
        from .contact import contact_history

        return contact_history(self, element, system)

    def section_loads(self, body, system=None):
        """Internal loads at the segment joints of a flexible body; see :func:`flexmb.post.sections.section_loads`.

        Parameters
        ----------
        body : FlexibleBody or str
            The body, or its name (looked up in ``system``, else in the
            system the result came from, ``Result.system``).
        system : System or Model, optional
            With it, also the components the body does not keep.

        Returns
        -------
        SectionField
            Values shape (nt, n_joints, n_components), ``stations`` (m),
            ``components`` and ``units``; ``.envelope()`` for the peaks.
        """
        from .sections import section_loads

        return section_loads(self, body, system)

    def section_strains(self, body, system=None):
        """Curvatures, twist and axial strain at the segment joints; see :func:`flexmb.post.sections.section_strains`.

        Parameters
        ----------
        body : FlexibleBody or str
            The body, or its name (looked up in ``system``, else in the
            system the result came from, ``Result.system``).
        system : System or Model, optional
            To look the body up by name.

        Returns
        -------
        SectionField
            Values shape (nt, n_joints, n_components).
        """
        from .sections import section_strains

        return section_strains(self, body, system)

    def section_stresses(self, body, system=None):
        """Outer-fibre and von Mises stresses at the segment joints; see :func:`flexmb.post.sections.section_stresses`.

        Parameters
        ----------
        body : FlexibleBody or str
            The body, or its name (looked up in ``system``, else in the
            system the result came from, ``Result.system``).
        system : System or Model, optional
            With it, the loads the body does not keep count too.

        Returns
        -------
        SectionField
            Stresses (Pa), shape (nt, n_joints, 6).
        """
        from .sections import section_stresses

        return section_stresses(self, body, system)

    def joint_loads(self, system=None):
        """Force and moment every joint transmits; see :func:`flexmb.post.joint_loads.joint_loads`.

        Parameters
        ----------
        system : System or Model, optional
            The model the result came from (default: the system that made
            it, which a result loaded from a file does not keep).

        Returns
        -------
        JointLoads
            ``force`` and ``moment`` (nt, n_joints, 3) in each joint's
            child marker frame, ``names``.
        """
        from .joint_loads import joint_loads

        if system is None:
            system = self.system
        if system is None:
            raise ModelError("joint_loads needs the system the result came from (a loaded result does not keep "
                             "it): res.joint_loads(system)")
        return joint_loads(self, system)
