"""Shared fixtures, model builders, and the ``slow`` marker (skipped unless --runslow)."""

from __future__ import annotations

import signal
import sys

import numpy as np
import pytest

try:
    import flexmb as fm
except ModuleNotFoundError as exc:  # run without installing: say what to do instead of 30 import errors
    raise pytest.UsageError(
        f"flexmb is not installed in this Python ({exc}); run the README's test command: "
        'python -m pip install -e ".[test]" && python -m pytest'
    ) from exc


def pytest_addoption(parser):
    parser.addoption("--runslow", action="store_true", default=False, help="run slow benchmark-like tests")


@pytest.fixture(autouse=True, scope="session")
def answers_ctrl_c():
    """Ctrl-C (SIGINT) answered by Python's handler for the session, as in a run started in the foreground.

    A shell without job control starts a background command (``nohup
    python -m pytest ... &``) with SIGINT ignored, and Python then keeps it
    ignored: the tests that send Ctrl-C to this process (a run stopped as
    interrupted, :class:`flexmb._signals.deferred`, an interrupted wait for
    forked children) saw nothing, failed together, and the wait hung. The
    library rightly leaves an ignored SIGINT ignored; the tests need it
    answered. Processes the tests start then get SIGINT's default, as from a
    foreground run.
    """
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        yield
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    else:
        yield


#: the signals a test sends to a process of its own to see flexmb answer them
ANSWERED = tuple(getattr(signal, s) for s in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, s))

#: starts the command after it with SIGINT, SIGTERM and SIGHUP at their defaults (then ``exec``: the same pid)
_DEFAULTS = ("import os, signal, sys\n"
             "for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):\n"
             "    signal.signal(s, signal.SIG_DFL)\n"
             "os.execvp(sys.argv[1], sys.argv[1:])")


def with_default_signals(argv) -> list:
    """``argv`` run with SIGINT, SIGTERM and SIGHUP at their defaults, as from a terminal, however the suite started.

    flexmb leaves a signal ignored at its start ignored (``nohup``'s SIGHUP,
    a background command's SIGINT), and a child inherits an ignored signal:
    a test that signals a child to see flexmb answer it would see nothing
    in a suite started with ``nohup``. The command runs in the same process
    (``exec``), so its pid is the one :class:`subprocess.Popen` gives.

    Parameters
    ----------
    argv : sequence of str
        The command line; ``argv[0]`` a program (looked up in PATH, as a shell does).

    Returns
    -------
    list of str
    """
    return [sys.executable, "-c", _DEFAULTS, *argv]


@pytest.fixture
def signals_answered():
    """SIGTERM and SIGHUP at their defaults for a test that sends them to the test process, where the suite
    ignores them (started with ``nohup``); put back afterwards (Ctrl-C: :func:`answers_ctrl_c`)."""
    saved = {s: signal.getsignal(s) for s in ANSWERED if s != signal.SIGINT}
    for s, handler in saved.items():
        if handler == signal.SIG_IGN:
            signal.signal(s, signal.SIG_DFL)
    yield
    for s, handler in saved.items():
        signal.signal(s, handler)


def pytest_collection_modifyitems(config, items):
    if config.getoption("--runslow"):
        return
    skip = pytest.mark.skip(reason="slow: run with --runslow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


JOINT_TYPES = [fm.Revolute, fm.Prismatic, fm.Cylindrical, fm.Universal, fm.Spherical, fm.Fixed, fm.Free]


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def random_body(rng, name):
    """A rigid body with random mass, a random valid inertia and mass-centre offset."""
    moments = np.sort(rng.uniform(0.2, 1.0, 3))
    moments[2] = min(moments[2], 0.99 * (moments[0] + moments[1]))
    Q = random_rotation(rng)
    return fm.RigidBody(name, rng.uniform(0.5, 2.0), Q @ np.diag(moments) @ Q.T, rng.normal(scale=0.3, size=3))


def random_chain(rng, types=None, branch=True, gravity=True):
    """A random open tree mixing the given joint types, with random frames and points."""
    model = fm.Model("random")
    types = types or JOINT_TYPES
    bodies = [model.ground]
    for i, cls in enumerate(types):
        b = random_body(rng, f"b{i}")
        parent = bodies[rng.integers(len(bodies))] if branch else bodies[-1]
        kw = dict(parent_point=rng.normal(size=3), child_point=rng.normal(size=3),
                  parent_frame=random_rotation(rng), child_frame=random_rotation(rng))
        if cls is fm.Universal:
            kw.pop("parent_frame")
            kw.pop("child_frame")
            R = random_rotation(rng)
            kw.update(axis=R[:, 0], axis2=R[:, 1])
        model.add(cls(f"j{i}", parent, b, **kw))
        bodies.append(b)
    if gravity:
        model.add(fm.Gravity((0.0, -9.81, 0.0)))
    return model


def slender_pendulum_chain(n_links, length=1.0, mass=1.0, g=9.81):
    """Planar chain of slender bars hanging from the ground, revolute about z."""
    model = fm.Model("chain")
    parent, point = model.ground, (0.0, 0.0, 0.0)
    for i in range(n_links):
        bar = fm.RigidBody.slender_bar(f"bar{i}", mass, length)
        model.add(fm.Revolute(f"pin{i}", parent, bar, parent_point=point, axis=(0, 0, 1)))
        parent, point = bar, (length, 0.0, 0.0)
    model.add(fm.Gravity((0.0, -g, 0.0)))
    return model


def fourbar(complement_joint=fm.PlanarRevolute):
    """Benchmark B5: planar four-bar under gravity along -y.

    Ground pivots (0, 0) and (0.3, 0); crank 0.1 m, coupler 0.3 m,
    rocker 0.25 m; uniform slender bars of 1 kg/m. Body frames sit at each
    bar's first end; in the reference configuration all bars lie along +x.
    The coupler-rocker joint closes the loop.
    """
    model = fm.Model("fourbar")
    crank = fm.RigidBody.slender_bar("crank", 0.1, 0.1)
    coupler = fm.RigidBody.slender_bar("coupler", 0.3, 0.3)
    rocker = fm.RigidBody.slender_bar("rocker", 0.25, 0.25)
    model.add(
        fm.Revolute("A", model.ground, crank, axis=(0, 0, 1)),
        fm.Revolute("B", crank, coupler, parent_point=(0.1, 0, 0), axis=(0, 0, 1)),
        fm.Revolute("D", model.ground, rocker, parent_point=(0.3, 0, 0), axis=(0, 0, 1)),
        complement_joint("C", coupler, rocker, parent_point=(0.3, 0, 0), child_point=(0.25, 0, 0),
                         axis=(0, 0, 1)),
        fm.Gravity((0.0, -9.81, 0.0)),
    )
    return model


def fourbar_initial(theta=np.pi / 4):
    """Closed initial angles (crank, coupler relative, rocker) for crank angle theta, coupler up."""
    a, b, c, d = 0.1, 0.3, 0.25, 0.3
    B = a * np.array([np.cos(theta), np.sin(theta)])
    D = np.array([d, 0.0])
    dist = np.linalg.norm(D - B)
    # circle intersection: C at distance b from B and c from D, above the line
    ex = (D - B) / dist
    l = (b * b - c * c + dist * dist) / (2 * dist)
    h = np.sqrt(b * b - l * l)
    ey = np.array([-ex[1], ex[0]])
    C = B + l * ex + h * ey
    phi_b = np.arctan2(*(C - B)[::-1])
    phi_c = np.arctan2(*(C - D)[::-1])
    return {"A": theta, "B": phi_b - theta, "D": phi_c}


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
