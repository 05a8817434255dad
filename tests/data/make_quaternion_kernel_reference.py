"""Write quaternion_kernel_reference.npz: models in Euler parameters on the Python evaluation path.

Generated on main at commit 26de9e9, where a joint in Euler parameters
(``rotation='quaternion'``) computed its motion in Python
(``SphericalQuaternion.motion``) and its models were evaluated without the
compiled tree kernels. tests/test_quaternion_kernel.py checks that the
compiled kernels give the same rates, runs, linearisation and statics to
1e-10 (runs whose integrator uses no Jacobian of flexmb's, which the
compiled route makes exact, or its own differences). Rerun only to add
cases, from a checkout of that commit:

    python tests/data/make_quaternion_kernel_reference.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexmb as fm

HERE = Path(__file__).resolve().parent


def heavy_top():
    """A heavy top on a ball joint in Euler parameters, tilted 100 deg (beyond the horizontal) and spinning."""
    model = fm.Model("top")
    top = fm.RigidBody("top", 1.0, np.diag([0.02, 0.02, 0.01]), com=(0.0, 0.0, 0.1))
    model.add(fm.Spherical("pivot", model.ground, top, rotation="quaternion"), fm.Gravity((0.0, 0.0, -9.81)))
    a = np.radians(100.0)
    return model, dict(positions={"pivot.qy": np.sin(a / 2), "pivot.qw": np.cos(a / 2)}, speeds={"pivot.wz": 40.0})


def tumbling():
    """An asymmetric body on a Free joint in Euler parameters, moving and tumbling about its intermediate axis."""
    model = fm.Model("tumbling")
    body = fm.RigidBody("body", 1.0, np.diag([1.0, 2.0, 3.0]))
    model.add(fm.Free("float", model.ground, body, rotation="quaternion"))
    return model, dict(speeds={"float.x": 0.5, "float.wx": 0.05, "float.wy": 1.0, "float.wz": 0.05})


def chain():
    """Two ball joints and a free joint in Euler parameters, offset frames, gravity, forces and a spring."""
    model = fm.Model("chain")
    a = fm.RigidBody("a", 1.0, (0.02, 0.03, 0.01), com=(0.1, 0.0, -0.3))
    b = fm.RigidBody("b", 2.0, (0.05, 0.02, 0.04), com=(0.0, 0.2, -0.2))
    c = fm.RigidBody("c", 0.5, (0.01, 0.02, 0.03), com=(0.05, 0.05, 0.05))
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    model.add(fm.Spherical("j1", model.ground, a, rotation="quaternion"),
              fm.Spherical("j2", a, b, parent_point=(0.1, 0.0, -0.5), parent_frame=turn, rotation="quaternion"),
              fm.Free("j3", b, c, parent_point=(0.0, 0.3, -0.3), child_point=(0.02, 0.0, 0.0), rotation="quaternion"),
              fm.Gravity((0.0, 0.0, -9.81)), fm.PointForce("push", c, (1.0, 2.0, -3.0), point=(0.1, 0.0, 0.0)),
              fm.BodyTorque("twist", b, (0.1, -0.2, 0.05), frame="body"),
              fm.SpringDamper("tie", b, (0.0, 0.0, -0.4), c, (0.0, 0.0, 0.0), stiffness=40.0, damping=0.5))
    return model, dict(positions={"j1": [0.1, 0.2, 0.0, 1.0], "j3": [0.0, 0.0, 0.1, 0.0, 0.3, 0.1, 1.0]},
                       speeds={"j1.wx": 1.0, "j2.wy": -2.0, "j3.wz": 3.0, "j3.x": 0.2})


def loop():
    """A crank driving a rod on a ball joint in Euler parameters; the rod's far end on a slider (a cut ball joint)."""
    model = fm.Model("rssp")
    crank = fm.RigidBody.slender_bar("crank", 1.0, 0.2)
    rod = fm.RigidBody("rod", 1.0, (1e-3, 0.03, 0.03), com=(0.3, 0.0, 0.0))
    slider = fm.RigidBody("slider", 1.0, (0.01, 0.01, 0.01))
    model.add(fm.Revolute("pin", model.ground, crank, axis=(0, 0, 1)),
              fm.Spherical("ball", crank, rod, parent_point=(0.2, 0, 0), rotation="quaternion"),
              fm.Prismatic("rail", model.ground, slider, axis=(1, 0, 0)),
              fm.Spherical("end", rod, slider, parent_point=(0.6, 0, 0), cut=True),
              fm.Gravity((0.0, -9.81, 0.0)))
    return model, dict(positions={"pin": 0.7, "rail": 0.75, "ball": [0.0, 0.0, -0.3, 1.0]}, speeds={"pin": 1.0})


def gear_beside_free():
    """Two shafts coupled by a gear pair (a constraint element) beside a free body in Euler parameters."""
    model = fm.Model("gears")
    s1 = fm.RigidBody("s1", 1.0, (0.02, 0.02, 0.02))
    s2 = fm.RigidBody("s2", 1.0, (0.5, 0.5, 0.5))
    model.add(fm.Revolute("shaft1", model.ground, s1), fm.Revolute("shaft2", model.ground, s2),
              fm.GearPair("teeth", "shaft1", "shaft2", ratio=-3.0),
              fm.JointSpringDamper("spring", "shaft1", stiffness=40.0),
              fm.Free("float", model.ground, fm.RigidBody("probe", 1.0, (0.1, 0.2, 0.3)), rotation="quaternion"))
    return model, dict(positions={"shaft1": 0.4, "shaft2": -0.4 / 3.0},
                       speeds={"float.wx": 0.3, "float.wy": 2.0, "float.wz": 0.2})


def runs():
    """(name, model, simulate keyword arguments) of the runs in the reference."""
    model, ic = heavy_top()
    yield "top_dop853", model, dict(t_end=0.5, method="DOP853", rtol=1e-9, **ic)
    yield "top_rk45", model, dict(t_end=0.3, method="RK45", rtol=1e-8, **ic)
    model, ic = tumbling()
    yield "tumbling_dop853", model, dict(t_end=2.0, method="DOP853", rtol=1e-9, **ic)
    model, ic = chain()
    yield "chain_dop853", model, dict(t_end=0.4, method="DOP853", rtol=1e-9, track_work=True, **ic)
    model, ic = loop()
    yield "loop_dop853", model, dict(t_end=0.3, method="DOP853", rtol=1e-9, **ic)
    model, ic = gear_beside_free()
    yield "gears_dop853", model, dict(t_end=0.5, method="DOP853", rtol=1e-9, **ic)


def run(model, kwargs):
    """The arrays of a run that must not change."""
    res = fm.simulate(model, n_out=21, progress=False, **kwargs)
    out = dict(t=res.t, x=res.x, xd=res.xd, xdd=res.xdd, steps=np.array(res.n_steps))
    if res.work:
        out.update({f"work.{k}": v for k, v in res.work.items()})
    return out


def rates():
    """The state rates of each model at random states (coordinates off unit length too), and its reactions."""
    rng = np.random.default_rng(29)
    for name, make in (("top", heavy_top), ("tumbling", tumbling), ("chain", chain), ("loop", loop),
                       ("gears", gear_beside_free)):
        system = make()[0].build()
        layout = system.layout
        states = []
        for scale in (1.0, 1.2):
            q = layout.reference() + 0.4 * rng.normal(size=layout.nq)
            q = layout.normalized(q)
            q[system.topology.quaternions[0]] *= scale
            states.append(layout.join(q, rng.normal(size=layout.n)))
        yield f"{name}_rates", dict(y=np.array(states), rate=np.array([system.state_rate(0.3, y) for y in states]))


def analyses():
    """Linearisation and statics of a pendulum on a ball joint in Euler parameters."""
    model = fm.Model()
    bob = fm.RigidBody("bob", 2.0, (0.01, 0.02, 0.03), com=(0.0, 0.0, -0.5))
    model.add(fm.Spherical("ball", model.ground, bob, rotation="quaternion"), fm.Gravity((9.81, 0.0, -9.81)),
              fm.PointForce("push", bob, (0.0, 2.0, 0.0), point=(0.2, 0.0, -0.5)))
    system = model.build()
    x0 = system.layout.normalized(np.array([0.1, 0.2, 0.0, 1.0]))
    lin = fm.linearize(system, x0, np.zeros(3))
    yield "pendulum_linearize", dict(M=lin.M, C=lin.C, K=lin.K)
    yield "pendulum_statics", dict(x=fm.static_equilibrium(system, x0))


def main():
    data = {}
    for name, model, kwargs in runs():
        for key, value in run(model, kwargs).items():
            data[f"{name}/{key}"] = value
    for group in (rates(), analyses()):
        for name, values in group:
            for key, value in values.items():
                data[f"{name}/{key}"] = value
    np.savez_compressed(HERE / "quaternion_kernel_reference.npz", **data)


if __name__ == "__main__":
    main()
