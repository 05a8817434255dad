"""The ``[initial]`` section of a scene file: positions, speeds, point and angular velocities, checked at load.

Coordinate speeds, ``[initial.point_velocities.<label>]`` and
``[initial.angular_velocities.<label>]`` become the ``speeds`` of
:func:`flexmb.initial_state` (:mod:`flexmb.initial_speeds`). Every key is
checked when the scene is read; then, if any speed is given, the initial
state is assembled once so that speeds contradicting a driver or a
constraint are refused at load, naming both (unless ``hold_speeds =
false`` lets the constraints win).
"""

from __future__ import annotations

import math

from ..errors import AssemblyError, FlexmbError
from ..initial_speeds import AngularVelocity, PointVelocity
from .settings import InitialState, _is_number, _toml_type

__all__: list[str] = []

#: the keys of ``[initial]``
INITIAL_KEYS = ("positions", "speeds", "fixed", "hold_speeds", "point_velocities", "angular_velocities")


def load_initial(loader) -> InitialState:
    """Read ``[initial]`` (names of coordinates are checked later, against the built system).

    Parameters
    ----------
    loader : _Loader
        The scene loader (its checks raise SceneError with key paths).

    Returns
    -------
    InitialState
    """
    t = loader.table("initial", loader.data.get("initial", {}))
    loader.keys("initial", t, optional=INITIAL_KEYS)
    out = {}
    for what in ("positions", "speeds"):
        values = _flatten(loader.table(f"initial.{what}", t.get(what, {})))
        for k, v in values.items():
            for x in (v if isinstance(v, list) else [v]):
                loader.number(f"initial.{what}.{k}", x)
        out[what] = dict(values)
    fixed = t.get("fixed", [])
    if not isinstance(fixed, list):
        loader.fail("initial.fixed", f"must be an array of coordinate or joint names, got {_toml_type(fixed)}")
    for i, f in enumerate(fixed):
        loader.string(f"initial.fixed[{i}]", f)
    hold = loader.boolean("initial.hold_speeds", t.get("hold_speeds", True))
    points = {label: _point_velocity(loader, f"initial.point_velocities.{label}", spec)
              for label, spec in loader.table("initial.point_velocities", t.get("point_velocities", {})).items()}
    omegas = {label: _angular_velocity(loader, f"initial.angular_velocities.{label}", spec)
              for label, spec in loader.table("initial.angular_velocities", t.get("angular_velocities", {})).items()}
    return InitialState(out["positions"], out["speeds"], tuple(fixed), hold, points, omegas)


def _point_velocity(loader, path: str, spec) -> PointVelocity:
    loader.table(path, spec)
    loader.keys(path, spec, required=("body", "point", "velocity"), optional=("directions",))
    body = _moving_body(loader, path, spec["body"])
    point = _vector(loader, f"{path}.point", spec["point"], "m, in the body frame")
    velocity = _vector(loader, f"{path}.velocity", spec["velocity"], "m/s, in inertial axes")
    directions = _directions(loader, f"{path}.directions", spec.get("directions"), "inertial axes")
    return PointVelocity(body, point, velocity, directions, name=path)


def _angular_velocity(loader, path: str, spec) -> AngularVelocity:
    loader.table(path, spec)
    loader.keys(path, spec, required=("body", "omega"), optional=("frame", "directions"))
    body = _moving_body(loader, path, spec["body"])
    frame = loader.string(f"{path}.frame", spec.get("frame", "inertial"))
    if frame not in ("inertial", "body"):
        loader.fail(f"{path}.frame", f"must be 'inertial' or 'body' (the axes of omega), got {frame!r}")
    omega = _vector(loader, f"{path}.omega", spec["omega"], f"rad/s, in {frame} axes")
    directions = _directions(loader, f"{path}.directions", spec.get("directions"), f"{frame} axes")
    return AngularVelocity(body, omega, frame, directions, name=path)


def _moving_body(loader, path: str, name) -> str:
    body = loader.ref(f"{path}.body", name, "body")
    if body.name == "ground":
        loader.fail(f"{path}.body", "the ground does not move: name a moving body")
    return body.name


def _vector(loader, path: str, value, unit: str) -> tuple:
    if not (isinstance(value, list) and len(value) == 3 and all(_is_number(x) for x in value)):
        got = f"{len(value)} values" if isinstance(value, list) else f"{_toml_type(value)} {value!r}"
        loader.fail(path, f"must be 3 numbers ({unit}), got {got}")
    out = tuple(float(x) for x in value)
    if not all(math.isfinite(x) for x in out):
        loader.fail(path, f"must be finite, got {value!r}")
    return out


def _directions(loader, path: str, value, axes: str):
    """None, or the directions as a list of 3-vectors (one direction may be given as a plain 3-vector)."""
    if value is None:
        return None
    rows = value if isinstance(value, list) and value and all(isinstance(r, list) for r in value) else [value]
    for i, row in enumerate(rows):
        where = f"{path}[{i}]" if rows is value else path
        v = _vector(loader, where, row, f"a direction in {axes}")
        if not any(v):
            loader.fail(where, "a direction must not be zero")
    return [list(map(float, r)) for r in rows]


def check_initial(loader, scene, system) -> None:
    """Check the names of ``[initial]`` against the system; then refuse speeds that contradict it.

    Parameters
    ----------
    loader : _Loader
    scene : Scene
    system : System
        ``scene.system()``.
    """
    initial = scene.initial
    for what, values in (("positions", initial.positions), ("speeds", initial.speeds),
                         ("fixed", dict.fromkeys(initial.fixed))):
        # positions per coordinate; speeds (and what is held) per speed: the names differ for Euler parameters
        names, kind = ((system.coordinate_names, "coordinate") if what == "positions" or system.layout.identity
                       else (system.speed_names, "speed"))
        joints = {n.rsplit(".", 1)[0] for n in names}
        for k, v in values.items():
            path = f"initial.{what}" + (f".{k}" if what != "fixed" else "")
            if k not in names and k not in joints:
                loader.fail(path, f"no {kind} or joint named {k!r}; {kind}s: {', '.join(names)}")
            if isinstance(v, list):
                count = sum(1 for n in names if n == k or n.rsplit(".", 1)[0] == k)
                if len(v) != count:
                    loader.fail(path, f"must have {count} values (one per {kind} of {k!r}), got {len(v)}")
    if not initial.gives_speeds():
        return
    try:
        scene.initial_state(system)
    except AssemblyError:
        return  # loops that cannot close are the run's to report, with the worst rows
    except FlexmbError as exc:
        message = str(exc).replace("pass hold_speeds=False", "set hold_speeds = false in [initial] "
                                                             "(hold_speeds=False in Python)")
        loader.fail("initial", message)


def _flatten(table: dict, prefix: str = "") -> dict:
    """``{B = {angle = 1}}`` (what TOML makes of the dotted key ``B.angle = 1``) -> ``{"B.angle": 1}``."""
    out = {}
    for k, v in table.items():
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out
