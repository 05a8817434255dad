"""The named outputs of a scene run: scalars (and time series) reduced from its result.

A scene file's ``[output.metrics]`` writes them into ``summary.json``; a
parameter study (:mod:`flexmb.study`) tabulates them over its cases.
"""

from __future__ import annotations

import numpy as np

from ..errors import FlexmbError

__all__ = ['OUTPUTS', 'default_outputs']


def _tracked(scene, res, label):
    return scene.track(res)[label]


def _peak_speed(scene, res, label):
    p = _tracked(scene, res, label)
    return float(np.linalg.norm(np.gradient(p, res.t, axis=0), axis=1).max())


def _peak_speed_exact(scene, res, label):
    return float(np.linalg.norm(_point_motion(scene, res, label, 1), axis=1).max())


def _point_motion(scene, res, label, derivative):
    """A tracked point's position, velocity or acceleration history, exact from the kinematics (eq. 17)."""
    from ..post.motion import point_motion

    # the system the result came from, kept on it (a loaded result has none: compile the scene's)
    body, point = scene.output.points[label]
    return point_motion(res, body, point, derivative, res.system if res.system is not None else scene.system())


def _position(scene, res, label):
    return _point_motion(scene, res, label, 0).tolist()


def _velocity(scene, res, label):
    return _point_motion(scene, res, label, 1).tolist()


def _acceleration(scene, res, label):
    return _point_motion(scene, res, label, 2).tolist()


def _peak_acceleration(scene, res, label):
    return float(np.linalg.norm(_point_motion(scene, res, label, 2), axis=1).max())


def _omega(scene, res, body, frame):
    from ..post.motion import angular_velocity

    system = res.system if res.system is not None else scene.system()
    return angular_velocity(res, body, frame, (0.0, 0.0, 0.0), system)


def _angular_velocity(scene, res, body):
    return _omega(scene, res, body, "inertial").tolist()


def _body_angular_velocity(scene, res, body):
    return _omega(scene, res, body, "body").tolist()


def _peak_angular_speed(scene, res, body):
    return float(np.linalg.norm(_omega(scene, res, body, "inertial"), axis=1).max())


def _max_displacement(scene, res, label):
    p = _tracked(scene, res, label)
    return float(np.linalg.norm(p - p[0], axis=1).max())


def _peak_effort(scene, res, driver):
    return float(np.abs(res.driver_effort(driver)).max())


def _driver_work(scene, res, driver):
    if f"driver {driver}" not in res.work:
        raise FlexmbError("driver_work needs [solver] track_work = true")
    return float(res.work[f"driver {driver}"][-1])


def _energy_balance(scene, res, _=None):
    # with track_work: sum of the works = change of kinetic energy; without: energy is conserved
    if res.work:
        works = np.array(list(res.work.values()))
        error = np.abs(works.sum(axis=0) - (res.kinetic - res.kinetic[0]))
        scale = max(np.abs(works).max(), np.abs(res.kinetic - res.kinetic[0]).max(), 1e-300)
    else:
        error = np.abs(res.energy - res.energy[0])
        scale = max(np.abs(res.kinetic).max(), np.abs(res.potential - res.potential[0]).max(), 1e-300)
    return float(error.max() / scale)


def _final(scene, res, coordinate):
    return float(res.coordinate(coordinate)[-1])


def _maximum(scene, res, coordinate):
    return float(res.coordinate(coordinate).max())


def _minimum(scene, res, coordinate):
    return float(res.coordinate(coordinate).min())


def _history(scene, res, coordinate):
    return res.coordinate(coordinate).tolist()


def _times(scene, res, _=None):
    return res.t.tolist()


def _max_residual(scene, res, _=None):
    return float(res.residual.max())


def _n_rhs(scene, res, _=None):
    return int(res.n_rhs)


#: built-in outputs: name -> (function(scene, result, argument), what the argument names or None, description)
OUTPUTS = {
    "peak_speed": (_peak_speed, "point", "largest speed of a tracked point ([output.points]), m/s"),
    "peak_speed_exact": (_peak_speed_exact, "point", "largest speed of a tracked point, exact from the kinematics "
                                                     "of each output state (eq. 17), m/s"),
    "max_displacement": (_max_displacement, "point", "largest distance of a tracked point from its start, m"),
    "position": (_position, "point", "a tracked point's inertial position at every output time, m (a time series of "
                                     "3-vectors)"),
    "velocity": (_velocity, "point", "a tracked point's inertial velocity at every output time, exact (eq. 17), m/s "
                                     "(a time series of 3-vectors)"),
    "acceleration": (_acceleration, "point", "a tracked point's inertial acceleration at every output time, exact, "
                                             "m/s^2 (a time series of 3-vectors)"),
    "peak_acceleration": (_peak_acceleration, "point", "largest acceleration of a tracked point, exact, m/s^2"),
    "angular_velocity": (_angular_velocity, "body", "a body's angular velocity in inertial axes at every output "
                                                    "time, rad/s (a time series of 3-vectors)"),
    "body_angular_velocity": (_body_angular_velocity, "body", "a body's angular velocity in its own axes at every "
                                                              "output time, rad/s (a time series of 3-vectors)"),
    "peak_angular_speed": (_peak_angular_speed, "body", "largest magnitude of a body's angular velocity, rad/s"),
    "peak_effort": (_peak_effort, "driver", "largest |torque| (N m) or |force| (N) a driver supplies"),
    "driver_work": (_driver_work, "driver", "work of a driver over the run, J (needs track_work)"),
    "energy_balance": (_energy_balance, None, "energy-balance error relative to the largest work or energy"),
    "final": (_final, "coordinate", "value of a coordinate at t_end"),
    "max": (_maximum, "coordinate", "largest value of a coordinate"),
    "min": (_minimum, "coordinate", "smallest value of a coordinate"),
    "history": (_history, "coordinate", "a coordinate at every output time (a time series)"),
    "time": (_times, None, "the output times, s (a time series)"),
    "max_residual": (_max_residual, None, "largest loop-closure residual"),
    "n_rhs": (_n_rhs, None, "right-hand-side evaluations (the cost, machine-independent)"),
}


def _check_output(spec, scene, system) -> None:
    """Raise if a named output does not fit the scene (checked once, before any case runs)."""
    if not isinstance(spec, str):
        if not (isinstance(spec, tuple) and len(spec) == 2 and isinstance(spec[0], str) and callable(spec[1])):
            raise FlexmbError(f"output {spec!r}: give a name such as 'peak_speed:tip' or a (name, function) pair")
        return
    name, _, arg = spec.partition(":")
    if name not in OUTPUTS:
        raise FlexmbError(f"unknown output {name!r}; pick one of {', '.join(OUTPUTS)} "
                          f"(or pass (name, function) in Python)")
    needs = OUTPUTS[name][1]
    if needs is None:
        if arg:
            raise FlexmbError(f"output {spec!r}: {name} takes no argument")
        return
    known = {"point": list(scene.output.points), "driver": [d.name for d in scene.model.drivers],
             "body": [b.name for b in scene.model.bodies],
             "coordinate": list(system.coordinate_names)
             + sorted({n.rsplit(".", 1)[0] for n in system.coordinate_names})}[needs]
    if arg not in known:
        plural = "bodies" if needs == "body" else f"{needs}s"
        raise FlexmbError(f"output {spec!r}: write {name}:<{needs}>; {plural} of this scene: "
                          f"{', '.join(known) or 'none'}")


def _is_real(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _output_name(spec) -> str:
    return spec if isinstance(spec, str) else spec[0]


def _evaluate(spec, scene, res):
    if isinstance(spec, str):
        name, _, arg = spec.partition(":")
        return OUTPUTS[name][0](scene, res, arg or None)
    value = spec[1](scene, res)
    return _plain(value)


def default_outputs(scene) -> list[str]:
    """The outputs of a study that names none: tracked points, drivers, energy balance, loop residual.

    Parameters
    ----------
    scene : Scene
        The scene.

    Returns
    -------
    list of str
        ``peak_speed:<point>`` for each tracked point, ``peak_effort:<driver>``
        for each driver, ``energy_balance``, ``max_residual`` and ``n_rhs``.
    """
    return ([f"peak_speed:{p}" for p in scene.output.points] + [f"peak_effort:{d.name}" for d in scene.model.drivers]
            + ["energy_balance", "max_residual", "n_rhs"])


def _plain(v):
    """numpy scalars to Python numbers (TOML-like and JSON-serialisable)."""
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v
