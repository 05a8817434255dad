"""Calibration of a flexible body's segment data to measured natural frequencies and mode shapes.

The paper (section 2) feeds finite segments with data "from analytical
solutions, or experimental modal analysis". :func:`calibrate` takes the
second route: it scales the elastic-joint springs (and optionally the
segment masses) of one :class:`~flexmb.FlexibleBody` so that the natural
frequencies (and optionally the mode shapes) of a test configuration match
given values, by nonlinear least squares (:func:`scipy.optimize.least_squares`)
on the frequencies computed by :func:`flexmb.modes`.

The scale factors are not free per joint: a body with 16 joints and 3
measured frequencies would be underdetermined. They follow a smooth profile
along the body with few parameters, the exponential of a Legendre series in
the arclength (positive by construction, and a zero parameter vector is the
uncalibrated body)::

    stiffness_scale(s_j) = exp(sum_{k < p} a_k P_k(2 s_j / L - 1))
    mass_scale(s_i)      = exp(sum_{1 <= k <= q} b_k P_k(2 s_i / L - 1)) / mean

at the joint stations s_j and the segment mid-points s_i; the mass profile
has no constant term and is normalised to keep the body's total mass (a
uniform scale of both stiffness and mass leaves every frequency unchanged,
so the two cannot be fitted together from frequencies alone; the total
mass is the one datum a test gives directly).
"""

from __future__ import annotations

import copy

import attrs
import numpy as np
from attrs import define
from scipy.optimize import least_squares

from ..errors import ModelError
from ..fields import label
from ..flexible import FlexibleBody
from .linear import modes

__all__ = ["Calibration", "calibrate"]

#: test configurations a bare body is calibrated in, and the zero-frequency modes each has
CONFIGURATIONS = {"clamped": 0, "free": 6}


@define
class Calibration:
    """What :func:`calibrate` fitted, and how well.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    body : FlexibleBody
        The calibrated body (the given one with ``stiffness_scale`` and
        ``mass_scale`` set); use it like any other.
    model : Model
        The model with the calibrated body: the given model, or the test
        configuration built around a bare body.
    stiffness_scale : ndarray, shape (n_joints,)
        Fitted factor on each joint spring (relative to the given body).
    mass_scale : ndarray, shape (n_segments,)
        Fitted factor on each segment's mass and inertia (ones unless masses
        were fitted).
    parameters : ndarray, shape (p + q,)
        The Legendre coefficients of ``log stiffness_scale`` (p), then of
        ``log mass_scale`` (q).
    target : ndarray, shape (m,)
        The frequencies fitted to, Hz.
    before, after : ndarray, shape (m,)
        The model's frequencies before and after, Hz.
    mac_before, mac_after : ndarray, shape (m,) or None
        Modal assurance criterion of each model mode against the given
        shape (1: parallel), when mode shapes were given.
    residual : float
        Norm of the weighted residual vector of the data at the solution
        (relative frequency errors and shape misfits).
    rank : int
        Numerical rank of the residuals' Jacobian in the parameters at the
        solution: how many parameter combinations the data determine (fewer
        than the parameters: the regularisation fixed the rest).
    success : bool
        Whether :func:`scipy.optimize.least_squares` converged.
    message : str
        Its message.
    nfev : int
        Number of modal analyses the fit took (its finite-difference
        Jacobians included).
    """

    body: FlexibleBody
    model: object
    stiffness_scale: np.ndarray
    mass_scale: np.ndarray
    parameters: np.ndarray
    target: np.ndarray
    before: np.ndarray
    after: np.ndarray
    mac_before: np.ndarray | None
    mac_after: np.ndarray | None
    residual: float
    rank: int
    success: bool
    message: str
    nfev: int

    @property
    def error_before(self) -> np.ndarray:
        """Relative frequency errors before calibration, ``before / target - 1``."""
        return self.before / self.target - 1.0

    @property
    def error_after(self) -> np.ndarray:
        """Relative frequency errors after calibration, ``after / target - 1``."""
        return self.after / self.target - 1.0

    def summary(self) -> str:
        """A table of the frequencies before and after, and the range of the factors.

        Returns
        -------
        str
            One line per frequency, then the factors and the fit's residual.
        """
        lines = [f"calibration of {self.body.name!r}: {'converged' if self.success else 'NOT converged'} "
                 f"after {self.nfev} modal analyses, residual {self.residual:.3g}, "
                 f"{self.rank} of {self.parameters.size} parameters determined by the data",
                 "  mode   target Hz   before Hz   error       after Hz    error"]
        for i, (t, b, a) in enumerate(zip(self.target, self.before, self.after)):
            lines.append(f"  {i + 1:<4d}  {t:10.5g}  {b:10.5g}  {b / t - 1:+.3e}  {a:10.5g}  {a / t - 1:+.3e}")
        lines.append(f"  stiffness scale {self.stiffness_scale.min():.6g} .. {self.stiffness_scale.max():.6g}; "
                     f"mass scale {self.mass_scale.min():.6g} .. {self.mass_scale.max():.6g}")
        if self.mac_after is not None:
            lines.append(f"  MAC before {np.round(self.mac_before, 6).tolist()}, "
                         f"after {np.round(self.mac_after, 6).tolist()}")
        return "\n".join(lines)


def _with_body(model, old: FlexibleBody, new: FlexibleBody):
    """A copy of ``model`` in which ``new`` replaces ``old`` (and every element that refers to it)."""
    out = copy.copy(model)
    out.bodies = [new if b is old else b for b in model.bodies]
    for group in ("joints", "forces", "drivers"):
        items = []
        for e in getattr(model, group):
            if attrs.has(type(e)):
                changes = {a.alias: new for a in attrs.fields(type(e)) if a.init and getattr(e, a.name) is old}
                if changes:
                    e = attrs.evolve(e, **changes)
            items.append(e)
        setattr(out, group, items)
    out._aliases = dict(model._aliases)
    return out


def _test_model(body: FlexibleBody, configuration: str):
    from ..joints import Fixed, Free
    from ..model import Model

    model = Model(f"{body.name} {configuration}")
    if configuration == "clamped":
        model.add(Fixed("clamp", model.ground, body))
    else:
        if body.clamped:
            raise ModelError(f"calibrate: {label(body)} has clamped = True (an elastic joint to a massless "
                             "clamp frame); a free-free test needs clamped = False")
        model.add(Free("free", model.ground, body))
    return model


def _which_body(model, body) -> FlexibleBody:
    flexible = [b for b in model.bodies if isinstance(b, FlexibleBody)]
    if body is None:
        if len(flexible) != 1:
            raise ModelError(f"calibrate: model {model.name!r} has {len(flexible)} flexible bodies "
                             f"{[b.name for b in flexible]}; name the one to calibrate with body=")
        return flexible[0]
    found = model.element(body, FlexibleBody)
    return found


def _rank(jac: np.ndarray) -> int:
    """Numerical rank of a Jacobian (singular values above 1e-6 of the largest)."""
    sv = np.linalg.svd(np.atleast_2d(jac), compute_uv=False)
    return int(np.sum(sv > 1e-6 * sv[0])) if sv.size and sv[0] > 0 else 0


def _legendre(s: np.ndarray, length: float, degree: int) -> np.ndarray:
    """P_0 .. P_degree at ``2 s / L - 1``, shape (len(s), degree + 1)."""
    return np.polynomial.legendre.legvander(2.0 * s / length - 1.0, degree)


def _station_matrix(system, body: FlexibleBody, stations: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Linear map from the coordinates x to the transverse displacement at the stations, shape (k, n).

    The direction is the body's z axis for bending about y (``bend_y``), y
    for ``bend_z``, in the reference state; the displacement of each station
    is differentiated through the full kinematics, so the body may sit
    anywhere in the model.
    """
    bends = [c for c in ("bend_y", "bend_z") if c in body.keep]
    if len(bends) != 1:
        raise ModelError(f"calibrate: mode shapes are transverse displacements in one plane; {label(body)} must "
                         f"keep exactly one of 'bend_y', 'bend_z', keeps {list(body.keep)}")
    topo = system.topology
    where = [topo.locate(body, np.array([s, 0.0, 0.0])) for s in stations]
    n = system.n_coords  # a flexible body's test set-up: its speeds are its coordinates' rates

    def points(x):
        kin = system.kinematics(0.0, x, np.zeros(system.n_speeds))
        return np.array([kin.origin[k] + kin.R[k] @ local for k, local in where]), kin

    _, kin0 = points(np.zeros(n))
    root = system.topology.index[system.topology.flexible[body][1][0]]  # the first segment, along the body frame
    direction = kin0.R[root][:, 2 if bends[0] == "bend_y" else 1]
    out = np.zeros((len(stations), n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        out[:, j] = (points(e)[0] - points(-e)[0]) @ direction / (2 * h)
    return out


def calibrate(target, frequencies, mode_shapes=None, *, stations=None, body=None, configuration: str | None = None,
              fit=("stiffness",), n_stiffness: int | None = None, n_mass: int | None = None, skip: int | None = None,
              shape_weight: float = 1.0, regularization: float = 0.0, tol: float = 1e-12,
              max_nfev: int = 200) -> Calibration:
    """Fit a flexible body's joint stiffnesses (and segment masses) to natural frequencies.

    Parameters
    ----------
    target : FlexibleBody or Model
        A bare body, analysed in ``configuration``; or a model, the test set-up
        itself (e.g. the body with a tip mass), whose flexible ``body`` is
        calibrated.
    frequencies : array_like, shape (m,)
        The measured (or reference) natural frequencies, Hz, matched in
        order to the model's m lowest elastic modes.
    mode_shapes : array_like, shape (k, m), optional
        The matching mode shapes: transverse displacements at ``stations``
        (any scale and sign), along the body's z axis if it keeps
        ``bend_y``, y for ``bend_z``. Each adds k residuals, the misfit
        ``(u - alpha v) / |u|`` of the model shape v scaled to the measured
        u by least squares (its square is ``1 - MAC``).
    stations : array_like, shape (k,), optional
        Arclengths of the measured points from the body's root, m.
    body : FlexibleBody or str, optional
        With a model: the body to calibrate (default its only flexible
        body).
    configuration : {'clamped', 'free'}, optional
        With a bare body: clamped at its root by a :class:`~flexmb.Fixed`
        joint to the ground (default), or free-free on a
        :class:`~flexmb.Free` joint (its 6 rigid-body modes are skipped; the
        body needs ``clamped=False``).
    fit : tuple of str
        ``('stiffness',)`` or ``('stiffness', 'mass')``.
    n_stiffness : int, optional
        Number p of Legendre terms of the log stiffness profile (default:
        m, or ceil(m / 2) when masses are fitted from frequencies alone;
        at most the number of joints).
    n_mass : int, optional
        Number q of Legendre terms of the log mass profile, without the
        constant (default, with 'mass': m - 1 with mode shapes, else
        m - p).
    skip : int, optional
        How many of the model's lowest modes to leave out before pairing
        (its rigid-body modes): default 6 for the 'free' configuration,
        else 0.
    shape_weight : float
        Weight of the shape residuals against the relative frequency errors.
    regularization : float
        Weight of the parameters themselves as extra residuals (Tikhonov),
        which picks the smallest change where the data leave a combination
        of parameters free. Off by default: from the uncalibrated body the
        trust-region steps of :func:`scipy.optimize.least_squares` already
        move little along such directions, and a weight slows the final
        convergence.
    tol : float
        ``ftol``, ``xtol`` and ``gtol`` of :func:`scipy.optimize.least_squares`.
    max_nfev : int
        Most modal analyses to spend.

    Returns
    -------
    Calibration
        The calibrated body and model, the factors, the frequencies before
        and after and the residual.

    Raises
    ------
    ModelError
        On bad input (no body, non-positive or non-finite frequencies, shapes
        of the wrong size, more parameters than residuals, an unknown
        configuration or fit).

    Notes
    -----
    Parametrisation (module docstring): the logarithm of each scale profile
    is a Legendre series along the body, so that a few measured frequencies
    fit a few smooth parameters and the problem is not underdetermined. With
    as many parameters as frequencies, the frequencies are matched to the
    solver's tolerance when the model can reach them. A symmetric test (a
    uniform free-free beam) does not see the odd terms of the profile to
    first order; give it ``n_stiffness = 2 m - 1`` (``Calibration.rank``
    shows how many combinations the data determined).

    Examples
    --------
    >>> import numpy as np
    >>> import flexmb as fm
    >>> beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005),
    ...                        fm.Material.aluminium(), 8, keep=("bend_y",))
    >>> eb = np.array([4.1126, 25.7733])  # Euler-Bernoulli f1, f2, Hz
    >>> cal = fm.calibrate(beam, eb)
    >>> np.abs(cal.error_before).round(3), bool(np.all(np.abs(cal.error_after) < 1e-6))
    (array([0.007, 0.024]), True)
    >>> cal.body.stiffness_scale.shape
    (8,)
    """
    where = "calibrate"
    f_target, with_mass = _check_targets(where, frequencies, fit)
    m = f_target.size
    body0, model0, skip = _test_setup(where, target, body, configuration, skip)
    st, shapes = _check_shapes(where, mode_shapes, stations, m, body0.length)
    n_res = m + (0 if shapes is None else shapes.size)
    fitter = _Fit(body0, model0, skip, f_target, shapes, with_mass, shape_weight, regularization,
                  *_basis_sizes(where, body0, m, with_mass, shapes is not None, n_stiffness, n_mass))
    p0 = np.zeros(fitter.n_parameters)
    body_p0, _, sys0, f_before, phi0 = fitter.evaluate(p0)
    # the stations' displacements are linear in x with a map fixed by the geometry, not by k or m
    fitter.S = None if shapes is None else _station_matrix(sys0, body_p0, st)
    sol = least_squares(fitter.residuals, p0, method="trf", x_scale=1.0, diff_step=1e-6, ftol=tol, xtol=tol,
                        gtol=tol, max_nfev=max_nfev)
    new, model, _, f_after, phi1 = fitter.evaluate(sol.x)
    ks, ms = fitter.scales(sol.x)
    return Calibration(body=new, model=model, stiffness_scale=ks, mass_scale=ms if with_mass else np.ones_like(ms),
                       parameters=sol.x, target=f_target, before=f_before, after=f_after,
                       mac_before=fitter.mac(phi0), mac_after=fitter.mac(phi1),
                       residual=float(np.linalg.norm(sol.fun[:n_res])), rank=_rank(sol.jac[:n_res]),
                       success=bool(sol.success), message=sol.message, nfev=fitter.count)


def _check_targets(where, frequencies, fit):
    """The target frequencies and whether masses are fitted too."""
    f_target = np.array(frequencies, dtype=float).ravel() if not isinstance(frequencies, str) else np.array([])
    if f_target.size == 0 or not np.all(np.isfinite(f_target)) or np.any(f_target <= 0):
        raise ModelError(f"{where}: frequencies must be finite numbers > 0, got {frequencies!r}")
    fit = (fit,) if isinstance(fit, str) else tuple(fit)
    if fit not in (("stiffness",), ("stiffness", "mass"), ("mass", "stiffness")):
        raise ModelError(f"{where}: fit must be ('stiffness',) or ('stiffness', 'mass'), got {fit!r}")
    return f_target, "mass" in fit


def _test_setup(where, target, body, configuration, skip):
    """The body fitted, the model of the test and the rigid-body modes to skip."""
    from ..model import Model

    if isinstance(target, FlexibleBody):
        configuration = "clamped" if configuration is None else configuration
        if configuration not in CONFIGURATIONS:
            raise ModelError(f"{where}: configuration must be one of {list(CONFIGURATIONS)}, got {configuration!r}")
        if body is not None:
            raise ModelError(f"{where}: body= is for a model; a body was given")
        body0, model0, rigid = target, _test_model(target, configuration), CONFIGURATIONS[configuration]
    elif isinstance(target, Model):
        if configuration is not None:
            raise ModelError(f"{where}: configuration is for a bare body; a model is its own test set-up")
        body0, model0, rigid = _which_body(target, body), target, 0
    else:
        raise ModelError(f"{where}: target must be a FlexibleBody or a Model, got {type(target).__name__}")
    skip = rigid if skip is None else skip
    if isinstance(skip, bool) or not isinstance(skip, (int, np.integer)) or skip < 0:
        raise ModelError(f"{where}: skip must be an integer >= 0, got {skip!r}")
    return body0, model0, skip


def _check_shapes(where, mode_shapes, stations, m, L):
    """The stations and the measured mode shapes, each normalised (None without shapes)."""
    if mode_shapes is None:
        return None, None
    if stations is None:
        raise ModelError(f"{where}: mode_shapes need the stations (arclengths) where they were measured")
    st = np.array(stations, dtype=float).ravel()
    shapes = np.array(mode_shapes, dtype=float)
    if shapes.ndim == 1:
        shapes = shapes[:, None]
    if shapes.shape != (st.size, m):
        raise ModelError(f"{where}: mode_shapes must have shape (len(stations), len(frequencies)) = "
                         f"{(st.size, m)}, got {shapes.shape}")
    if (not np.all(np.isfinite(shapes)) or not np.all(np.isfinite(st)) or np.any(st < 0) or np.any(st > L)
            or np.any(np.linalg.norm(shapes, axis=0) == 0)):
        raise ModelError(f"{where}: mode shapes must be finite and non-zero, stations within [0, {L:g}] m")
    return st, shapes / np.linalg.norm(shapes, axis=0)


def _basis_sizes(where, body0, m, with_mass, with_shapes, n_stiffness, n_mass):
    """The Legendre bases of the stiffness and mass scale profiles, at the joints and the segments."""
    # joint stations (the clamp joint at a quarter segment: the middle of its span) and segment mid-points
    l, L = body0.segment_length, body0.length
    s_joint = np.arange(0 if body0.clamped else 1, body0.n_segments) * l
    if body0.clamped:
        s_joint[0] = 0.25 * l
    s_seg = (np.arange(body0.n_segments) + 0.5) * l
    if n_stiffness is None:
        n_stiffness = m if (not with_mass or with_shapes) else (m + 1) // 2
    n_stiffness = int(min(n_stiffness, body0.n_joints))
    if not with_mass:
        n_mass = 0
    elif n_mass is None:
        n_mass = m - 1 if with_shapes else m - n_stiffness
    n_mass = int(min(n_mass, body0.n_segments - 1))
    if n_stiffness < 1 or n_mass < 0 or (with_mass and n_mass < 1):
        raise ModelError(f"{where}: need n_stiffness >= 1 (and n_mass >= 1 to fit masses), got "
                         f"{n_stiffness}, {n_mass}")
    return _legendre(s_joint, L, n_stiffness - 1), _legendre(s_seg, L, n_mass)[:, 1:]


class _Fit:
    """The least-squares problem of :func:`calibrate`: scale profiles, modal analysis, residuals."""

    def __init__(self, body0, model0, skip, f_target, shapes, with_mass, shape_weight, regularization, Pk, Pm):
        self.body0, self.model0, self.skip = body0, model0, skip
        self.f_target, self.shapes, self.with_mass = f_target, shapes, with_mass
        self.shape_weight, self.regularization = shape_weight, regularization
        self.Pk, self.Pm = Pk, Pm
        self.n_stiffness = Pk.shape[1]
        self.n_parameters = Pk.shape[1] + Pm.shape[1]
        self.m_seg = body0.segment_properties()[0]
        self.S = None
        self.count = 0  # modal analyses, the Jacobian's included (least_squares' nfev leaves those out)

    def scales(self, p):
        """Stiffness and mass scale factors of parameters ``p`` (the total mass kept)."""
        ks = np.exp(self.Pk @ p[: self.n_stiffness])
        ms = np.exp(self.Pm @ p[self.n_stiffness:])
        ms *= np.sum(self.m_seg) / np.sum(self.m_seg * ms)  # keep the total mass
        return ks, ms

    def evaluate(self, p):
        """The scaled body, its model and system, and the frequencies and shapes of the fitted modes."""
        ks, ms = self.scales(p)
        k0, m0 = self.body0.stiffness_scale, self.body0.mass_scale
        new = attrs.evolve(self.body0, stiffness_scale=ks if k0 is None else (k0.T * ks).T,
                           mass_scale=None if not self.with_mass else (ms if m0 is None else m0 * ms))
        model = _with_body(self.model0, self.body0, new)
        system = model.build()
        m = self.f_target.size
        f, phi = modes(system, self.skip + m)
        return new, model, system, f[self.skip:], phi[:, self.skip:]

    def residuals(self, p):
        """Relative frequency errors, weighted mode-shape misfits and the regularisation rows."""
        self.count += 1
        _, _, _, f, phi = self.evaluate(p)
        r = [f / self.f_target - 1.0]
        if self.shapes is not None:
            v = self.S @ phi
            alpha = np.sum(self.shapes * v, axis=0) / np.sum(v * v, axis=0)
            r.append(self.shape_weight * (self.shapes - alpha * v).ravel())
        if self.regularization:
            r.append(self.regularization * p)  # the smallest change wins where the data leave a direction free
        return np.concatenate(r)

    def mac(self, phi):
        """The modal assurance criterion of each fitted mode against the measured shape (None without shapes)."""
        if self.shapes is None:
            return None
        v = self.S @ phi
        return np.sum(self.shapes * v, axis=0) ** 2 / np.sum(v * v, axis=0)
