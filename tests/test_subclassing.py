"""Users subclass Joint, Body, ForceElement and ComplementStrategy directly, without registering."""

from __future__ import annotations

import numpy as np
from attrs import frozen

import flexmb as fm
from flexmb.complements import Complement, ComplementStrategy

from conftest import fourbar, fourbar_initial


@frozen(eq=False)
class SlideThenTurn(fm.Joint):
    """A user joint: slide along x, then turn about the new z (2 coordinates)."""

    translation_axes = (0,)
    rotation_axes = (2,)
    coordinate_names = ("slide", "angle")


@frozen(eq=False)
class PointMass(fm.Body):
    """A user body: a point mass with a tiny isotropic inertia."""

    mass: float = 1.0
    inertia: np.ndarray = np.eye(3) * 1e-6
    com: np.ndarray = np.zeros(3)


class QRComplement(ComplementStrategy):
    """A user strategy: null space from a column-pivoted QR of psi^T."""

    name = "qr"

    def _complement_impl(self, psi):
        import scipy.linalg as sla

        q, r, _ = sla.qr(psi.T, pivoting=True)
        d = np.abs(np.diag(r))
        rank = int(np.sum(d > self.tol * d[0]))
        u, s, vt = np.linalg.svd(psi @ q[:, :rank], full_matrices=False)
        return Complement(q[:, rank:].copy(), rank, q[:, :rank] @ vt.T, s, u)


def test_user_joint_and_body_simulate_with_energy_conserved():
    model = fm.Model()
    carriage = PointMass("carriage")
    joint = SlideThenTurn("user_joint", model.ground, carriage)
    model.add(joint, fm.JointSpringDamper("spring", joint, stiffness=(10.0, 0.0)))
    res = fm.simulate(model, 2.0, positions={"user_joint.slide": 0.1}, speeds={"user_joint.angle": 3.0},
                      rtol=1e-10, atol=1e-12)
    period = 2 * np.pi / np.sqrt(10.0)
    k = np.argmin(np.abs(res.t - period))
    assert abs(res.coordinate("user_joint.slide")[k] - 0.1 * np.cos(np.sqrt(10.0) * res.t[k])) < 1e-8
    assert np.ptp(res.energy) < 1e-10


def test_user_complement_strategy_agrees_with_svd():
    runs = {}
    for strategy in ("svd", QRComplement()):
        res = fm.simulate(fourbar(fm.Revolute), 0.5, positions=fourbar_initial(), fixed=["A"],
                          complement=strategy, rtol=1e-10, atol=1e-12)
        runs[res.complement] = res
    assert set(runs) == {"svd", "qr"}
    assert np.abs(runs["svd"].x - runs["qr"].x).max() < 1e-8
