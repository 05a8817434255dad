"""Arc-length path following of static equilibria (after constraint reduction).

The static equations in independent coordinates are ``R(x) = T^T g(x) = 0``
on ``phi(x) = 0``, with g the generalized active force at rest (eq. 5; at
zero speeds the force array of eq. 3 reduces to it) and T the orthogonal
complement of the constraint Jacobian (eqs. 30-39), so the constraint forces
never appear. A load factor lambda turns them into a one-parameter family
``R(x, lambda) = 0`` whose solutions form the load path; it is followed from
``lambda = 0`` by a predictor along the path's tangent and a Newton
corrector on the normal plane (Riks' arc-length method), which passes limit
points where a load-controlled Newton iteration fails, and reports the
limit points, the bifurcations and the stability of each state.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.linalg as sla

from ..assembly import ForceAssembler
from .._validate import state_vector
from ..errors import AssemblyError
from ..threads import limited_blas
from .loop_paths import LoopPathEquations, Stiffness, chosen_loads
from .loop_statics import _NewtonFailed, _NotConverged
from .paths import CriticalPoint, LoadPath, PathOptions, _list_limits

__all__ = ["load_path"]


class _Point(NamedTuple):
    """The static equations at one state: ``R = T^T g``, ``dR/dlambda``, ``J = dR/dz`` (or None)."""

    T: np.ndarray
    R: np.ndarray
    R_lam: np.ndarray
    J: np.ndarray | None


class _Equations:
    """``R(x, lambda) = T^T g(x, lambda)`` and its tangent, for one system, time and load.

    With ``load`` given, ``g = F_rest(x) + lambda F_load(x)``: the load's
    force elements are scaled, the rest (elastic elements, other loads) not.
    With ``load=None``, ``g = F(x) - (1 - lambda) F(x0)``: Newton's
    homotopy, which needs no separation of the loads.
    """

    def __init__(self, system, t, load, x0, h=1e-6):
        system.constraints.refuse_velocity_rows("static equilibrium")
        self.system, self.t, self.h = system, float(t), h
        self.zero = np.zeros(system.n_speeds)
        self.move = system.layout.displace  # coordinates moved along the speeds (x + W(x) d)
        elements = [e for _, group in system.forces.groups for e in group]
        if load is None:
            self.rest, self.load, self.name = system.forces, None, "Newton homotopy F(x) - (1 - lambda) F(x0)"
            self.ref = system.forces.active_force(self._kin(x0))
            return
        chosen = chosen_loads(system, load)
        self.rest = ForceAssembler([e for e in elements if not any(e is c for c in chosen)])
        self.load = ForceAssembler(chosen)
        self.name = ", ".join(e.name for e in chosen)
        self.ref = None

    def _kin(self, x):
        return self.system.kinematics(self.t, x, self.zero)

    def _forces(self, x, lam):
        """``g`` and ``dg/dlambda`` in all coordinates, and psi (None without constraints)."""
        kin = self._kin(x)
        F = self.rest.active_force(kin)
        if self.load is None:
            g, g_lam = F - (1.0 - lam) * self.ref, self.ref
        else:
            g_lam = self.load.active_force(kin)
            g = F + lam * g_lam
        psi = self.system.constraints.evaluate(kin, level=1).psi if self.system.n_constraints else None
        return g, g_lam, psi

    def project(self, x):
        try:
            return self.system.project(self.t, x, self.zero)[0]
        except AssemblyError as exc:  # a step too long for the loops to close: a failed step, not the end
            raise _NotConverged(f"the constraints cannot be closed ({exc})", np.inf, np.inf, 0) from None

    def __call__(self, x, lam, tangent=True) -> _Point:
        g, g_lam, psi = self._forces(x, lam)
        n = self.system.n_speeds
        mu = None
        if psi is None:
            T = np.eye(n)
        else:
            T = self.system.complement(psi).T
            # constraint forces psi^T mu: the least-squares balance of g, held fixed in the
            # differences below so that their geometric stiffness enters J
            mu = self.system._min_norm(psi.T, -g)
        R, R_lam = T.T @ g, T.T @ g_lam
        if not tangent:
            return _Point(T, R, R_lam, None)
        # central differences along the columns of T (tangent to phi = 0, so they need no
        # projection); g + psi^T mu is smooth in x, where T itself (an SVD basis) need not be
        J = np.empty((T.shape[1], T.shape[1]))
        for i in range(T.shape[1]):
            d = self.h * T[:, i]
            J[:, i] = T.T @ (self._balance(self.move(x, d), lam, mu) - self._balance(self.move(x, -d), lam, mu)) / (
                2 * self.h)
        return _Point(T, R, R_lam, J)

    def newton_step(self, pt, lam):
        """The Newton step ``T dz``, ``J dz = -R``, and ``max |dz|`` (:class:`_NewtonFailed` if J is singular)."""
        try:
            dz = -np.linalg.solve(pt.J, pt.R)
        except np.linalg.LinAlgError:
            raise _NewtonFailed("the tangent stiffness is singular") from None
        return pt.T @ dz, _norm(dz)

    def _balance(self, x, lam, mu):
        g, _, psi = self._forces(x, lam)
        return g if mu is None else g + psi.T @ mu

    def along(self, pt, lam):
        """``dx/dlambda = T v``, ``J v = -dR/dlambda`` (LinAlgError where J is singular)."""
        if pt.J.shape[0] and np.linalg.cond(pt.J) > 1e13:
            raise np.linalg.LinAlgError("singular tangent stiffness")
        return pt.T @ -np.linalg.solve(pt.J, pt.R_lam)

    def bordered(self, pt, lam, tx, tl, c, end, residual=True):
        """``(T dz, dl, max |dz|)`` of ``[J, R_lam; (T^T tx / c^2)^T, tl] [dz; dl] = [-R or 0; end]``."""
        p = pt.J.shape[0]
        M = np.zeros((p + 1, p + 1))
        M[:p, :p], M[:p, p] = pt.J, pt.R_lam
        M[p, :p], M[p, p] = pt.T.T @ tx / c**2, tl
        sol = np.linalg.solve(M, np.append(-pt.R if residual else np.zeros(p), end))
        return pt.T @ sol[:p], sol[p], _norm(sol[:p])

    def stiffness_at(self, pt, lam, previous):
        """The stability record: eigenvalues, ascending, of the symmetric part of ``K = -J``, and K."""
        K = -0.5 * (pt.J + pt.J.T)
        return Stiffness(np.linalg.eigvalsh(K) if K.size else np.zeros(0), K, None)


def _between(eq, x_a, x_b, u):
    """The coordinates a fraction ``u`` of the way from ``x_a`` to ``x_b``, along the speeds."""
    return eq.move(x_a, u * eq.system.layout.difference(x_b, x_a))


def _norm(v) -> float:
    return float(np.max(np.abs(v))) if v.size else 0.0


def _newton(eq, x, lam, tol, max_iter, counts, monotone=False):
    """Newton's method at a fixed load factor; returns (x, point at x)."""
    step, best = np.inf, np.inf
    for k in range(max_iter):
        pt = eq(x, lam)
        counts["tangents"] += 1
        counts["iterations"] += 1
        res = _norm(pt.R)
        if not np.isfinite(res):
            raise _NotConverged("the forces are not finite", step, res, k)
        if monotone and res > best and step > 1e3 * tol:
            raise _NotConverged("the residual grew", step, res, k)
        best = min(best, res)
        try:
            dx, size = eq.newton_step(pt, lam)
            x = eq.project(eq.move(x, dx))
        except _NewtonFailed as exc:
            raise _NotConverged(str(exc), step, res, k) from None
        step = size
        if step < tol:
            return x, eq(x, lam, tangent=False)
    raise _NotConverged(f"no convergence in {max_iter} Newton steps", step, _norm(pt.R), max_iter)


def _tangent(eq, pt, lam, prev, c):
    """Unit tangent (t_x, t_lam) of the path, oriented along ``prev`` (or towards growing lambda)."""
    if prev is None:
        tx, tl = eq.along(pt, lam), 1.0
    else:
        # bordered system [J R_lam; prev] t = [0; 1]: regular at limit points, where J is singular
        tx, tl, _ = eq.bordered(pt, lam, prev[0], prev[1], c, 1.0, residual=False)
    size = np.sqrt(tx @ tx / c**2 + tl**2)
    return tx / size, tl / size


def _hermite_extreme(s0, s1, l0, l1, d0, d1):
    """Where a cubic Hermite lambda(s) with end slopes d0, d1 of opposite sign has its extreme: (s, lambda)."""
    h = s1 - s0
    # lambda(u) = l0 + h (d0 u + a u^2 + b u^3), u in [0, 1]
    dl = (l1 - l0) / h
    a, b = 3 * dl - 2 * d0 - d1, d0 + d1 - 2 * dl
    roots = np.roots([3 * b, 2 * a, d0]) if abs(b) > 1e-14 else np.roots([2 * a, d0])
    roots = [r.real for r in roots if abs(r.imag) < 1e-12 and -1e-9 <= r.real <= 1 + 1e-9]
    u = roots[0] if roots else 0.5
    return s0 + u * h, l0 + h * (d0 * u + a * u**2 + b * u**3), u


class _Path:
    """Accumulates the accepted points of a path and finds its limit points."""

    def __init__(self, eq, x, lam, residual, pt):
        self.eq = eq
        self.lam, self.x, self.residual, self.arc, self.t_lam, self.t_x = [lam], [x], [residual], [0.0], [None], [None]
        self.K = [None, eq.stiffness_at(pt, lam, None)]  # the stability records of the last two points
        self.eigs = [self.K[1].eigs]
        self.limits, self.bifurcations = [], []
        self.counts = {"iterations": 0, "tangents": 0, "steps": 0, "rejected": 0}

    def add(self, x, lam, residual, ds, tx, tl, pt):
        self.lam.append(lam)
        self.x.append(x)
        self.residual.append(residual)
        self.arc.append(self.arc[-1] + ds)
        self.t_lam.append(tl)
        self.t_x.append(tx)
        self.K = [self.K[1], self.eq.stiffness_at(pt, lam, self.K[1])]
        self.eigs.append(self.K[1].eigs)

    def n_unstable(self) -> np.ndarray:
        return np.array([_count_negative(e) for e in self.eigs], dtype=int)

    def check_bifurcation(self):
        """Record a bifurcation if the last step changed the number of unstable directions without turning."""
        i = len(self.lam) - 2
        k0, k1 = _count_negative(self.eigs[i]), _count_negative(self.eigs[i + 1])
        if k0 == k1 or (self.limits and self.limits[-1].index == i):
            return
        # the eigenvalue that crossed zero: sorted ascending, it is number min(k0, k1)
        j = min(k0, k1)
        e0, e1 = self.eigs[i][j], self.eigs[i + 1][j]
        u = e0 / (e0 - e1) if e0 != e1 else 0.5
        # refined with the tangent stiffness interpolated linearly over the step (exact where it is
        # linear in lambda, as on the straight path of a perfect column): K0 + u (K1 - K0) singular
        K0, K1 = (record.K for record in self.K)
        try:
            if K0 is None or K1 is None or K0.shape != K1.shape:  # no common basis: the linear estimate stands
                raise ValueError
            roots = sla.eigvals(K0, K0 - K1)
            roots = roots.real[(np.abs(roots.imag) < 1e-9) & (roots.real >= 0) & (roots.real <= 1)]
            if roots.size:
                u = float(roots[np.argmin(np.abs(roots - u))])
        except (ValueError, np.linalg.LinAlgError):
            pass
        self.bifurcations.append(CriticalPoint(
            lam=float(self.lam[i] + u * (self.lam[i + 1] - self.lam[i])),
            x=self.x[i] + u * (self.x[i + 1] - self.x[i]), arc=float(self.arc[i] + u * (self.arc[i + 1] - self.arc[i])),
            index=i, kind="bifurcation"))

    def set_tangent(self, tx, tl):
        self.t_x[-1], self.t_lam[-1] = tx, tl

    def turned(self) -> bool:
        """Whether dlambda/ds changed sign over the last step."""
        return len(self.lam) > 1 and self.t_lam[-2] is not None and self.t_lam[-2] * self.t_lam[-1] < 0

    def add_limit(self, options, c):
        """Locate the limit point of the last step: secant iteration on the step length for dlambda/ds = 0."""
        i = len(self.lam) - 2
        x_a, lam_a, tx_a, tl_a = self.x[i], self.lam[i], self.t_x[i], self.t_lam[i]
        h = self.arc[i + 1] - self.arc[i]
        s, lam, u = _hermite_extreme(0.0, h, lam_a, self.lam[i + 1], tl_a, self.t_lam[i + 1])
        # cubic Hermite interpolation of x (as a displacement from x_a), the fallback if the secant iteration fails
        h10, h01, h11 = u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
        d = self.eq.system.layout.difference(self.x[i + 1], x_a)
        x = self.eq.move(x_a, h10 * h * tx_a + h01 * d + h11 * h * self.t_x[i + 1])
        lo, f_lo, hi, f_hi = 0.0, tl_a, h, self.t_lam[i + 1]
        kept = 0  # which end the last two brackets kept (Illinois: halve a stuck end's value)
        try:
            for _ in range(20):
                x_s, lam_s, pt, _ = _corrector(self.eq, x_a, lam_a, tx_a, tl_a, s, c, options, self.counts)
                f = _tangent(self.eq, pt, lam_s, (tx_a, tl_a), c)[1]
                x, lam = x_s, lam_s
                if abs(f) < 1e-10 or hi - lo < options.tol:
                    break
                if f * f_lo > 0:
                    lo, f_lo = s, f
                    f_hi, kept = (f_hi / 2 if kept == 1 else f_hi), 1
                else:
                    hi, f_hi = s, f
                    f_lo, kept = (f_lo / 2 if kept == -1 else f_lo), -1
                s = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        except (_NotConverged, np.linalg.LinAlgError):
            pass
        self.limits.append(CriticalPoint(lam=float(lam), x=np.asarray(x), arc=float(self.arc[i] + s), index=i,
                                      kind="maximum" if tl_a > 0 else "minimum"))

    def result(self, reached) -> LoadPath:
        c = self.counts
        return LoadPath(lam=np.array(self.lam), x=np.array(self.x), residual=np.array(self.residual),
                        arc=np.array(self.arc), limit_points=list(self.limits),
                        bifurcations=list(self.bifurcations), n_unstable=self.n_unstable(), load=self.eq.name,
                        coordinate_names=list(self.eq.system.coordinate_names), reached=reached,
                        n_steps=c["steps"], n_rejected=c["rejected"], n_iterations=c["iterations"],
                        n_tangents=c["tangents"])


def _count_negative(eigs) -> int:
    # negative beyond round-off, relative to the largest stiffness
    return int(np.sum(eigs < -1e-9 * np.max(np.abs(eigs)))) if eigs.size else 0


def _fail(message, path):
    err = AssemblyError(message)
    err.path = path.result(False)
    return err


def _follow(eq, x, lam, lam_end, options, tol_end, who="load path"):
    """Follow the path from the equilibrium (x, lam) until lambda reaches lam_end."""
    pt = eq(x, lam)
    path = _Path(eq, x, lam, _norm(pt.R), pt)
    path.counts["tangents"] += 1
    direction = 1.0 if lam_end >= lam else -1.0
    try:
        tx, tl = _tangent(eq, pt, lam, None, 1.0)
    except np.linalg.LinAlgError:
        raise _fail(f"{who}: the tangent stiffness is singular at the start (load factor {lam:.6g}, residual "
                    f"{_norm(pt.R):.3g}, load to carry {_norm(pt.R_lam):.3g}): a mechanism with no stiffness "
                    f"against the load ({eq.name})?", path) from None
    c = float(np.linalg.norm(tx)) / abs(tl) if tl else 1.0
    c = c if c > 0 and np.isfinite(c) else 1.0
    tx, tl = _tangent(eq, pt, lam, None, c)
    tx, tl = direction * tx, direction * tl
    path.set_tangent(tx, tl)
    ds = options.step
    while path.counts["steps"] < options.max_steps:
        x_a, lam_a = path.x[-1], path.lam[-1]
        try:
            x_new, lam_new, pt_new, k = _corrector(eq, x_a, lam_a, tx, tl, ds, c, options, path.counts)
        except _NotConverged as exc:
            path.counts["rejected"] += 1
            if ds / 2 < options.min_step:
                raise _fail(
                    f"{who} stopped at load step {path.counts['steps'] + 1} from load factor {lam_a:.6g} "
                    f"(target {lam_end:.6g}; {eq.name}): {exc.why} in a step of {ds:.3g}, and half of it is below "
                    f"the minimum {options.min_step:.3g}; residual {exc.residual:.3g}, last correction {exc.step:.3g}",
                    path) from None
            ds /= 2
            continue
        path.counts["steps"] += 1
        crossed = (lam_a - lam_end) * (lam_new - lam_end) <= 0 and lam_new != lam_a
        if crossed:
            # the target lies in this step: interpolate, then Newton at the target load factor
            u = (lam_end - lam_a) / (lam_new - lam_a)
            try:
                x_end, pt_end = _newton(eq, eq.project(_between(eq, x_a, x_new, u)), lam_end, tol_end,
                                        max(options.max_iter, 20), path.counts)
            except _NotConverged as exc:
                path.counts["rejected"] += 1
                ds /= 2
                if ds < options.min_step:
                    raise _fail(f"{who}: no equilibrium found at the target load factor {lam_end:.6g} near load step "
                                f"{path.counts['steps']}: {exc.why}; residual {exc.residual:.3g}", path) from None
                path.counts["steps"] -= 1
                continue
            pt_end = eq(x_end, lam_end)
            path.counts["tangents"] += 1
            path.add(x_end, float(lam_end), _norm(pt_end.R), ds * u, *_tangent_or(eq, pt_end, lam_end, tx, tl, c))
            path.check_bifurcation()
            return path.result(True)
        try:
            tx_new, tl_new = _tangent(eq, pt_new, lam_new, (tx, tl), c)
        except np.linalg.LinAlgError:
            raise _fail(f"{who}: the path's tangent is undefined at load step {path.counts['steps']}, load "
                        f"factor {lam_new:.6g} (a bifurcation?); residual {_norm(pt_new.R):.3g}", path) from None
        if tx_new @ tx / c**2 + tl_new * tl < options.max_turn and ds / 2 >= options.min_step:
            # the path turned too much in one step: it may have jumped to another branch
            path.counts["steps"] -= 1
            path.counts["rejected"] += 1
            ds /= 2
            continue
        tx, tl = tx_new, tl_new
        path.add(x_new, lam_new, _norm(pt_new.R), ds, tx, tl, pt_new)
        if path.turned():
            path.add_limit(options, c)
            if len(path.limits) >= options.max_limit_points:
                peaks = [p.lam for p in path.limits if (p.kind == "maximum") == (direction > 0)]
                raise _fail(f"{who}: load factor {lam_end:.6g} not reached ({eq.name}): the path turned "
                            f"back at {len(path.limits)} limit points (load factors {_list_limits(path.limits)}) "
                            f"by load step {path.counts['steps']}, residual {path.residual[-1]:.3g}; the "
                            f"structure carries load factors up to {direction * max(direction * v for v in peaks):.6g}",
                            path)
        path.check_bifurcation()
        ds = min(options.max_step, ds * (1.5 if k < options.iterations else 0.7 if k > options.iterations else 1.0))
    raise _fail(f"{who}: load factor {lam_end:.6g} not reached in {options.max_steps} load steps ({eq.name}); "
                f"reached {path.lam[-1]:.6g} (largest {max(path.lam, key=lambda v: direction * v):.6g}"
                + (f", limit points at {_list_limits(path.limits)}" if path.limits else "")
                + f"), residual {path.residual[-1]:.3g}: can the structure carry the load?", path)


def _tangent_or(eq, pt, lam, tx, tl, c):
    """The unit tangent at ``pt`` (or ``(tx, tl)`` where it is undefined), and ``pt``: the rest of :meth:`_Path.add`."""
    try:
        return (*_tangent(eq, pt, lam, (tx, tl), c), pt)
    except np.linalg.LinAlgError:
        return tx, tl, pt


def _corrector(eq, x_a, lam_a, tx, tl, ds, c, options, counts):
    """One arc-length step: predictor along the tangent, Newton on the normal plane (Riks)."""
    x = eq.project(eq.move(x_a, ds * tx))
    lam = lam_a + ds * tl
    step = np.inf
    for k in range(1, options.max_iter + 1):
        pt = eq(x, lam)
        counts["tangents"] += 1
        counts["iterations"] += 1
        res = _norm(pt.R)
        if not np.isfinite(res):
            raise _NotConverged("the forces are not finite", step, res, k)
        # normal plane through the predictor: (x - x_a) . tx / c^2 + (lam - lam_a) tl = ds
        plane = eq.system.layout.difference(x, x_a) @ tx / c**2 + (lam - lam_a) * tl - ds
        try:
            dx, dl, size = eq.bordered(pt, lam, tx, tl, c, -plane)
            x = eq.project(eq.move(x, dx))
        except np.linalg.LinAlgError:
            raise _NotConverged("the bordered tangent matrix is singular", step, res, k) from None
        except _NewtonFailed as exc:
            raise _NotConverged(str(exc), step, res, k) from None
        lam = lam + dl
        step = max(size, abs(dl))
        if step < options.tol:
            counts["tangents"] += 1
            return x, lam, eq(x, lam), k
    raise _NotConverged(f"no convergence in {options.max_iter} Newton steps", step, res, options.max_iter)


def _start(system, x0):
    n = system.n_coords
    return system.layout.reference() if x0 is None else state_vector("static equilibrium", "x0", x0, n).copy()


@limited_blas
def load_path(system, load=None, x0=None, t: float = 0.0, *, lam_end: float = 1.0, tol: float = 1e-10,
              options: PathOptions | None = None) -> LoadPath:
    """Follow the equilibrium path of a structure as a load grows (arc-length continuation).

    Solves ``R(x, lambda) = T^T g(x, lambda) = 0`` for a curve of
    equilibria starting at ``lambda = 0``, until the load factor reaches
    ``lam_end``, passing limit points (snap-through) on the way.

    Parameters
    ----------
    system : System
        Compiled model.
    load : ForceElement, str, sequence of them, or None
        The load that the factor scales: force elements of the model (or
        their names); ``g = F_rest(x) + lambda F_load(x)``, the rest of the
        forces (elastic elements, other loads) at full value. None scales
        all forces through Newton's homotopy ``g = F(x) - (1 - lambda)
        F(x0)``: from an unstressed ``x0`` (where F holds only the loads) it
        is load stepping of all the loads, and it needs no separation of
        loads from elastic forces.
    x0 : ndarray, shape (n,), optional
        Starting configuration (default zeros). With a named load it need
        not be an equilibrium of the other forces: the start is first
        solved for at ``lambda = 0`` by Newton's method.
    t : float
        Time, s (the loads and drivers are evaluated at this time).
    lam_end : float
        Target load factor; the last point is solved for at exactly it.
    tol : float
        Convergence at ``lam_end`` and at the start: the largest Newton
        correction of a coordinate (rad or m) below ``tol``.
    options : PathOptions, optional
        Step control (default :class:`PathOptions` ()).

    Returns
    -------
    LoadPath
        Load factors, coordinates, residuals, stability, limit points and
        bifurcations along the path.

    Raises
    ------
    AssemblyError
        If the path cannot be followed (a step fails at the minimum step
        length, the tangent stiffness is singular at the start, or
        ``lam_end`` is not reached in ``options.max_steps`` steps); the
        message names the load step, the load factor reached and the
        residual, and the error's ``path`` attribute holds the partial path.
    ModelError
        If ``load`` names no force element of the model.

    Notes
    -----
    Predictor: the unit tangent of the path, from the bordered system
    ``[J, dR/dlambda; t_prev] t = [0; 1]``, regular at limit points where
    the tangent stiffness ``J = dR/dz`` is singular. Corrector: Newton's
    method on the bordered equations of ``R = 0`` and the normal plane
    through the predicted point (Riks 1979; Crisfield 1991, ch. 9). The
    arc length weighs the coordinates by ``c = |dx/dlambda|`` at the start,
    so steps are in load-factor units. The step grows 1.5 times after a
    step that needed fewer than ``options.iterations`` Newton iterations,
    shrinks to 0.7 after more, and is halved after a failed one.

    J comes from central differences of ``g + psi^T mu`` along the columns
    of T, with the constraint multipliers mu (the least-squares balance of
    g) held fixed, so the geometric stiffness of the constraint forces (the
    axial force of a truss bar held by a loop joint) is in J; it is the
    exact reduced tangent, whatever basis the complement strategy picks.
    It costs ``2 p`` evaluations of the forces (no mass matrix). The
    analytic tangent of :meth:`System.state_jacobian` is not used: made
    for implicit integrators, it leaves out the constraint forces' change,
    and its geometric stiffness keeps the resultant wrench at each mass
    centre fixed in direction, which misses the turning lever arm of a
    force applied off the mass centre (a tip force); Newton's method would
    then converge only linearly.

    For loops closed by the articulated strategy none of psi, T or J is
    formed (:mod:`flexmb.analysis.loop_paths`, O(n m) per product): the
    bordered systems are solved by GMRES in the null space of psi,
    preconditioned as :func:`static_equilibrium`'s Newton steps; the
    residual is then ``g + psi^T mu`` and the corrector's step ``max |dx|``.

    Stability: at each point the eigenvalues of the symmetric part of the
    reduced tangent stiffness ``-J`` are counted (``LoadPath.n_unstable``,
    the negative ones). Where that count changes over a step with no limit
    point, the path has crossed a bifurcation (buckling); it is located
    where the tangent stiffness, interpolated linearly over the step,
    turns singular (a generalized eigenvalue problem; exact on the straight
    path of a perfect column), and reported, not followed: the path goes on
    along the branch it is on.

    A limit point is found where ``dlambda/ds`` changes sign between two
    path points, and located by a secant iteration on the length of the
    step from the first of them for ``dlambda/ds = 0`` (started from a
    cubic Hermite interpolation of the load factor, which is kept if the
    iteration fails).

    References
    ----------
    .. [1] E. Riks, "An incremental approach to the solution of snapping
       and buckling problems", Int. J. Solids Struct. 15 (1979) 529-551.
    .. [2] M. A. Crisfield, "Non-linear Finite Element Analysis of Solids
       and Structures", vol. 1, Wiley (1991).

    Examples
    --------
    A pinned bar held up by gravity against a torque of twice what its
    weight can carry: the load factor peaks where the bar is horizontal,
    at ``lambda = m g (L / 2) / torque = 0.5``.

    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = m.add(fm.Revolute("pin", m.ground, bar, axis=(0, 1, 0)), fm.Gravity((9.81, 0, 0)),
    ...           fm.BodyTorque("lift", bar, (0.0, -9.81, 0.0)))
    >>> path = fm.load_path(m.build(), "lift", lam_end=0.4)
    >>> round(float(path.x[-1, 0]), 6)  # asin(0.8), the bar raised
    -0.927295
    """
    options = PathOptions() if options is None else options
    x = _start(system, x0)
    x = system.project(t, x, np.zeros(system.n_speeds))[0]
    # loops closed by the articulated strategy: T, psi and J never formed (loop_paths.py)
    eq = LoopPathEquations(system, t, load, x) if system._loop_kernel else _Equations(system, t, load, x)
    counts = {"iterations": 0, "tangents": 0}
    if load is not None:
        try:
            x, _ = _newton(eq, x, 0.0, tol, 50, counts)
        except _NotConverged as exc:
            raise AssemblyError(f"load path: no equilibrium without the load ({eq.name}) at load factor 0: "
                                f"{exc.why}; residual {exc.residual:.3g}, last correction {exc.step:.3g}") from None
    path = _follow(eq, x, 0.0, lam_end, options, tol)
    path.n_iterations += counts["iterations"]
    path.n_tangents += counts["tangents"]
    return path


