"""Hypothesis generators of flexmb models: random trees of all joint types, closed loops, bad input.

A model is drawn as a *spec*, a list of plain dicts (one per joint and its
child body), then built; an invalid model is a valid spec with one field
spoiled, so that the element to blame is known. Loops are consistent by
construction: a tree is posed at a random configuration x*, and each cut
joint is placed where its two markers coincide at x* (same point, same
world frame), so x* closes every loop.
"""

from __future__ import annotations

import os
import signal
from contextlib import contextmanager

import numpy as np
from hypothesis import strategies as st

import flexmb as fm

JOINTS = [fm.Revolute, fm.Prismatic, fm.Cylindrical, fm.Universal, fm.Spherical, fm.Fixed, fm.Free,
          fm.PlanarRevolute]
#: joint types that may close a loop (Free imposes nothing; Fixed would often lock the loop)
CUTS = [fm.Revolute, fm.PlanarRevolute, fm.Prismatic, fm.Cylindrical, fm.Universal, fm.Spherical]

floats = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
vectors = st.tuples(floats, floats, floats).map(np.array)


@st.composite
def rotations(draw):
    """A rotation matrix from a random (normalised) quaternion."""
    q = np.array(draw(st.tuples(floats, floats, floats, floats)))
    n = np.linalg.norm(q)
    if n < 1e-3:
        return np.eye(3)
    w, x, y, z = q / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


@st.composite
def body_data(draw):
    """Mass (kg), a valid central inertia (kg m^2, triangle inequality kept) and a mass-centre offset (m)."""
    mass = draw(st.floats(0.1, 10.0))
    a, b = draw(st.floats(0.05, 1.0)), draw(st.floats(0.05, 1.0))
    c = draw(st.floats(abs(a - b) + 0.01, a + b - 0.01)) if a + b - 0.01 > abs(a - b) + 0.01 else (a + b) / 2
    Q = draw(rotations())
    inertia = Q @ np.diag([a, b, c]) @ Q.T
    return {"mass": mass, "inertia": (inertia + inertia.T) / 2, "com": draw(vectors) * 0.3}


@st.composite
def tree_specs(draw, min_joints=1, max_joints=4):
    """Joints of all types joining new bodies to the ground or an earlier body; at least one coordinate."""
    n = draw(st.integers(min_joints, max_joints))
    specs = []
    for i in range(n):
        cls = draw(st.sampled_from(JOINTS if i else [c for c in JOINTS if c is not fm.Fixed]))
        R = draw(rotations())
        spec = {"cls": cls, "name": f"j{i}", "body": f"b{i}", "parent": draw(st.integers(-1, i - 1)),
                "parent_point": draw(vectors), "child_point": draw(vectors), **draw(body_data())}
        if cls is fm.Universal:
            spec.update(axis=R[:, 0], axis2=R[:, 1])
        else:
            spec.update(parent_frame=R, child_frame=draw(rotations()))
        specs.append(spec)
    return specs


def build_tree(specs, gravity=(0.0, -9.81, 0.0)):
    """Build a Model from a spec; returns the model and its bodies by name."""
    model = fm.Model("random")
    bodies = {}
    for s in specs:
        body = fm.RigidBody(s["body"], s["mass"], s["inertia"], s["com"])
        parent = model.ground if s["parent"] < 0 else bodies[f"b{s['parent']}"]
        kw = {k: s[k] for k in ("parent_point", "child_point", "parent_frame", "child_frame", "axis", "axis2")
              if k in s}
        model.add(s["cls"](s["name"], parent, body, **kw))
        bodies[s["body"]] = body
    if gravity is not None:
        model.add(fm.Gravity(gravity))
    return model, bodies


@st.composite
def states(draw, n, scale=1.0):
    """Coordinates in [-scale, scale] (away from the Bryant-angle singularity at 90 deg) and speeds."""
    x = np.array(draw(st.lists(floats, min_size=n, max_size=n))) * scale
    xd = np.array(draw(st.lists(floats, min_size=n, max_size=n)))
    return x, xd


@st.composite
def loop_models(draw, max_joints=3):
    """A random tree closed by one or two cut joints that are consistent by construction.

    Returns
    -------
    model : Model
    x_star : ndarray
        Tree coordinates at which every loop is closed.
    """
    specs = draw(tree_specs(min_joints=2, max_joints=max_joints))
    model, bodies = build_tree(specs)
    system = model.build()
    x_star, _ = draw(states(system.n_coords, scale=0.8))
    kin = system.kinematics(0.0, x_star, np.zeros_like(x_star))
    names = list(bodies)
    for c in range(draw(st.integers(1, 2))):
        child = bodies[draw(st.sampled_from(names))]
        others = [None] + [b for b in names if bodies[b] is not child]
        other = draw(st.sampled_from(others))
        parent = model.ground if other is None else bodies[other]
        kc = system.index(child)
        Rc, oc = kin.R[kc], kin.origin[kc]
        if other is None:
            Rp, op = np.eye(3), np.zeros(3)
        else:
            kp = system.index(parent)
            Rp, op = kin.R[kp], kin.origin[kp]
        child_point = draw(vectors)
        world = oc + Rc @ child_point
        Fp = draw(rotations())
        Fc = Rc.T @ Rp @ Fp  # the same world frame at x*
        cls = draw(st.sampled_from(CUTS))
        model.add(cls(f"cut{c}", parent, child, parent_point=Rp.T @ (world - op), child_point=child_point,
                      parent_frame=Fp, child_frame=Fc, cut=True))
    return model, x_star


# ----------------------------------------------------------------------------- bad input

BAD_NUMBERS = [float("nan"), float("inf"), -float("inf")]


@st.composite
def bad_body_fields(draw):
    """One invalid body field: (field, value, what the message must mention)."""
    return draw(st.sampled_from([
        ("mass", draw(st.sampled_from(BAD_NUMBERS + [0.0, -1.0, "heavy", None])), "mass"),
        ("mass", -draw(st.floats(1e-300, 1e6)), "mass"),
        ("inertia", np.diag([1.0, 1.0, 5.0]), "triangle"),
        ("inertia", np.diag([1.0, -0.5, 1.0]), "inertia"),
        ("inertia", np.array([[1.0, 0.5, 0], [0, 1, 0], [0, 0, 1]]), "symmetric"),
        ("inertia", np.eye(2), "inertia"),
        ("inertia", np.diag([1.0, draw(st.sampled_from(BAD_NUMBERS)), 1.0]), "inertia"),
        ("com", np.array([0.0, draw(st.sampled_from(BAD_NUMBERS)), 0.0]), "com"),
        ("com", np.zeros(2), "com"),
    ]))


@st.composite
def bad_joint_fields(draw, cls):
    """One invalid joint field for a joint class: (field, value, what the message must mention)."""
    bad = draw(st.sampled_from(BAD_NUMBERS))
    options = [("parent_point", np.array([bad, 0.0, 0.0]), "parent_point"),
               ("child_point", np.zeros(4), "child_point"),
               ("name", draw(st.sampled_from(["", "  ", None, 7])), "name")]
    if cls is fm.Universal:
        options += [("axis", np.zeros(3), "axis"), ("axis2", np.array([1.0, 1.0, 0.0]), "perpendicular")]
    else:
        options += [("parent_frame", np.diag([1.0, 1.0, -1.0]), "rotation"),
                    ("child_frame", 2 * np.eye(3), "rotation")]
    if cls in (fm.Revolute, fm.PlanarRevolute, fm.Prismatic, fm.Cylindrical):
        options += [("axis", np.zeros(3), "axis"), ("axis", np.array([0.0, bad, 1.0]), "axis")]
    return draw(st.sampled_from(options))


# ----------------------------------------------------------------------------- flexible bodies, sizes, settings
# (issue 18 section 5: the generators above never built a FlexibleBody, nor drew sizes or solver settings)

ELASTIC = ["bend_y", "bend_z", "torsion", "axial", "shear_y", "shear_z"]


@st.composite
def flexible_bodies(draw, name="beam", max_segments=6):
    """A valid FlexibleBody: random length, rectangular section, material, N, kept coordinates, root, damping."""
    length = draw(st.floats(0.2, 2.0))
    section = fm.Section.rectangular(draw(st.floats(0.005, 0.05)), draw(st.floats(0.002, 0.02)))
    material = draw(st.sampled_from([fm.Material.aluminium(), fm.Material.steel()]))
    keep = tuple(draw(st.lists(st.sampled_from(ELASTIC[:3]), min_size=1, max_size=3, unique=True)))
    clamped = draw(st.booleans())
    n = draw(st.integers(1 if clamped else 2, max_segments))  # unclamped, one segment has no elastic joint
    # a whole float is a valid count too (it used to pass the check and fail at build)
    n_segments = draw(st.sampled_from([n, float(n), np.int64(n)]))
    return fm.FlexibleBody(name, length, section, material, n_segments, keep=keep,
                           damping=draw(st.sampled_from([0.0, 1e-4, 1e-3])), clamped=clamped)


@st.composite
def flexible_models(draw):
    """A flexible beam on a revolute or fixed root, possibly carrying a rigid tip body, under gravity."""
    model = fm.Model("flexible")
    beam = draw(flexible_bodies())
    root = fm.Fixed if beam.clamped else fm.Revolute
    model.add(beam, root("root", model.ground, beam, parent_frame=draw(rotations())))
    if draw(st.booleans()):
        tip = fm.RigidBody("tip", **draw(body_data()))
        model.add(fm.Revolute("tip_pin", beam, tip, parent_point=(beam.length, 0.0, 0.0)))
    model.add(fm.Gravity((0.0, -9.81, 0.0)))
    return model


@st.composite
def bad_flexible_fields(draw):
    """One invalid FlexibleBody argument: (field, value, what the message must mention)."""
    bad = draw(st.sampled_from(BAD_NUMBERS))
    return draw(st.sampled_from([
        ("n_segments", draw(st.sampled_from(BAD_NUMBERS + [None, 0, -3, 2.5, "4", True, [4]])), "n_segments"),
        ("length", draw(st.sampled_from([bad, 0.0, -1.0])), "length"),
        ("damping", draw(st.sampled_from([bad, -1.0])), "damping"),
        ("keep", (), "keep at least one"),
        ("keep", ("bend_x",), "unknown elastic coordinate"),
        ("keep", ("bend_y", "bend_y"), "keep lists a coordinate twice"),
        ("section", "strip", "section"),
    ]))


@st.composite
def bad_shapes(draw):
    """An invalid named-constructor call: (constructor, args, what the message must mention)."""
    bad = draw(st.sampled_from(BAD_NUMBERS + [0.0, -1.0, -1e-300, None]))
    size = [1.0, 1.0, 1.0]
    size[draw(st.integers(0, 2))] = bad
    return draw(st.sampled_from([
        (fm.RigidBody.slender_bar, ("bar", 1.0, bad), "length"),
        (fm.RigidBody.box, ("block", 1.0, size), "size"),
        (fm.RigidBody.box, ("block", 1.0, size[:2]), "size"),
    ]))


#: sizes no machine holds: dense n x n arrays of these would need terabytes
HUGE_COUNTS = [100_000, 1_000_000]


@st.composite
def simulate_arguments(draw):
    """Valid keyword arguments of simulate: short spans, tolerances, output counts and step limits."""
    return {"t_end": draw(st.floats(1e-4, 2e-2)), "rtol": draw(st.floats(1e-10, 1e-3)),
            "atol": draw(st.sampled_from([None, 1e-12, 1e-8])), "n_out": draw(st.sampled_from([1, 2, 7, 50, 7.0])),
            "max_step": draw(st.sampled_from([np.inf, 1e-2, 1e-3])),
            "projection_tol": draw(st.sampled_from([1e-10, 1e-8]))}


@st.composite
def bad_simulate_arguments(draw):
    """One invalid argument of simulate: (keyword, value, what the message must mention)."""
    bad = draw(st.sampled_from(BAD_NUMBERS))
    return draw(st.sampled_from([
        ("t_end", draw(st.sampled_from([float("inf"), float("nan"), 0.0, -1.0])), "t_end"),
        ("t0", bad, "t0"),
        ("rtol", draw(st.sampled_from([bad, 0.0, -1.0, "tight"])), "rtol"),
        ("atol", draw(st.sampled_from([bad, -1e-9])), "atol"),
        ("n_out", draw(st.sampled_from([0, -1, 2.5, None, bad])), "n_out"),
        ("n_out", draw(st.sampled_from([10**8, 10**12])), "output times"),
        ("max_step", draw(st.sampled_from([0.0, -1.0, float("nan")])), "max_step"),
        ("projection_tol", draw(st.sampled_from([bad, 0.0, -1.0])), "projection_tol"),
    ]))



@contextmanager
def memory_limit(size: str | None):
    """Cap the memory flexmb may plan for (``FLEXMB_MEMORY_LIMIT``), e.g. ``"8G"``; None leaves it alone.

    Keeps the refusals machine-independent: 1e8 output times fit a machine
    with 64 GB, and a future O(n) core may fit 100,000 segments.
    """
    old = os.environ.get("FLEXMB_MEMORY_LIMIT")
    if size is not None:
        os.environ["FLEXMB_MEMORY_LIMIT"] = size
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("FLEXMB_MEMORY_LIMIT", None)
        else:
            os.environ["FLEXMB_MEMORY_LIMIT"] = old


class _Hang(BaseException):
    """Raised by the alarm when one example runs too long (not an Exception, so nothing swallows it)."""


@contextmanager
def alarm(seconds: float):
    """Raise :class:`_Hang` in the main thread if the block runs longer than ``seconds``."""
    def ring(signum, frame):
        raise _Hang(f"no answer after {seconds} s")

    old = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
