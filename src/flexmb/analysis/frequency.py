"""Frequency responses of state-space models (Bode diagrams)."""

from __future__ import annotations

import numpy as np
from attrs import define

from ..errors import ModelError
from .._validate import whole
from .statespace import _check_frequencies

__all__ = ["FrequencyResponse", "frequency_response"]


@define
class FrequencyResponse:
    """Transfer functions ``H(j w)`` of chosen input-output pairs over frequency.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    w : ndarray, shape (n_w,)
        Angular frequencies, rad/s.
    response : ndarray, shape (n_w, n_pairs), complex
        ``H(j w)`` per pair (output units per input unit).
    pairs : list of tuple of str
        ``(input, output)`` per column.

    Examples
    --------
    >>> import numpy as np
    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    >>> pin = fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1))
    >>> system = m.add(pin, fm.JointSpringDamper("spring", pin, 3.0, 0.1)).build()
    >>> fr = fm.frequency_response(fm.state_space(system, ["pin"], ["pin"]), w=[0.0, 3.0])
    >>> fr.magnitude[:, 0].round(4)  # 1 / |k - I w^2 + j c w|, I = 1/3: 1 / k, then 1 / (c w) at resonance
    array([0.3333, 3.3333])
    >>> fr.pairs
    [('pin', 'pin')]
    """

    w: np.ndarray
    response: np.ndarray
    pairs: list

    @property
    def f(self) -> np.ndarray:
        """Frequencies, Hz, shape (n_w,)."""
        return self.w / (2 * np.pi)

    @property
    def magnitude(self) -> np.ndarray:
        """``|H|``, shape (n_w, n_pairs)."""
        return np.abs(self.response)

    @property
    def magnitude_db(self) -> np.ndarray:
        """``20 log10 |H|``, dB, shape (n_w, n_pairs)."""
        with np.errstate(divide="ignore"):
            return 20 * np.log10(self.magnitude)

    @property
    def phase(self) -> np.ndarray:
        """Phase of H, degrees, unwrapped along frequency, shape (n_w, n_pairs)."""
        return np.degrees(np.unwrap(np.angle(self.response), axis=0))

    def pair(self, input, output) -> np.ndarray:
        """``H(j w)`` of one pair.

        Parameters
        ----------
        input, output : str
            Their names.

        Returns
        -------
        ndarray, shape (n_w,), complex
            ``H(j w)`` of that pair.

        Raises
        ------
        ModelError
            If the pair was not computed.
        """
        if (input, output) not in self.pairs:
            raise ModelError(f"no pair {(input, output)!r}; pairs: {self.pairs}")
        return self.response[:, self.pairs.index((input, output))]

    def plot(self, path=None, *, hz: bool = True, db: bool = True, figsize=(7.0, 6.0)):
        """Bode diagram: magnitude and phase against frequency (matplotlib).

        Parameters
        ----------
        path : str or path-like, optional
            Save the figure there (PNG, PDF, ... by its ending).
        hz : bool
            Frequency axis in Hz (default) or rad/s.
        db : bool
            Magnitude in dB (default) or on a log scale.
        figsize : tuple of float
            Figure size, inches.

        Returns
        -------
        matplotlib.figure.Figure
            Two axes: magnitude above, phase below, one line per pair.

        Raises
        ------
        ExportError
            If matplotlib is not installed.
        """
        fig, (mag, ph) = _figure(path, figsize, 2)
        x = self.f if hz else self.w
        for i, (u, y) in enumerate(self.pairs):
            label = f"{u} \u2192 {y}"
            if db:
                mag.semilogx(x, self.magnitude_db[:, i], label=label)
            else:
                mag.loglog(x, self.magnitude[:, i], label=label)
            ph.semilogx(x, self.phase[:, i], label=label)
        mag.set_ylabel("magnitude (dB)" if db else "magnitude")
        ph.set_ylabel("phase (deg)")
        ph.set_xlabel("frequency (Hz)" if hz else "frequency (rad/s)")
        if len(self.pairs) <= 12:
            mag.legend(fontsize="small")
        for ax in (mag, ph):
            ax.grid(True, which="both", alpha=0.3)
        from ..viz.plots import _finish

        return _finish(fig, path)


def _figure(path, figsize, rows):
    """A figure with ``rows`` axes sharing x: pyplot's when shown, a bare Figure when saved."""
    from ..errors import ExportError

    try:
        import matplotlib  # noqa: F401
    except ImportError as exc:
        raise ExportError("plots need matplotlib: pip install 'flexmb[viz]'") from exc
    if path is None:
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(rows, 1, sharex=True, figsize=figsize, squeeze=False)
    else:
        from matplotlib.figure import Figure

        fig = Figure(figsize=figsize)
        axes = fig.subplots(rows, 1, sharex=True, squeeze=False)
    return fig, list(axes[:, 0])


def _default_w(ss, n: int) -> np.ndarray:
    """From a decade below the slowest nonzero pole to a decade above the fastest."""
    lam = np.abs(ss.poles())
    lam = lam[lam > 1e-9 * max(np.max(lam, initial=0.0), 1e-300)]
    if not lam.size:
        return np.logspace(-1, 3, n)
    return np.logspace(np.log10(np.min(lam) / 10), np.log10(np.max(lam) * 10), n)


def _frequencies(what, value) -> np.ndarray:
    """The frequencies given to :func:`frequency_response`: a 1-d array of finite real numbers, or a ModelError."""
    try:
        if isinstance(value, (str, bytes)) or np.iscomplexobj(value):
            raise TypeError
        a = np.atleast_1d(np.asarray(value, dtype=float))
    except (TypeError, ValueError, OverflowError):
        raise ModelError(f"frequency_response: {what} must be an array of real numbers, got {value!r:.60}") from None
    if a.ndim != 1 or a.size == 0:
        raise ModelError(f"frequency_response: {what} must be a 1-d array of frequencies, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        i = int(np.flatnonzero(~np.isfinite(a))[0])
        raise ModelError(f"frequency_response: {what} must be finite, got {what}[{i}] = {a[i]}")
    return a


def frequency_response(ss, w=None, *, f=None, pairs=None, n: int = 400) -> FrequencyResponse:
    """Frequency response ``H(j w) = C (j w I - A)^-1 B + D`` of a state-space model.

    Parameters
    ----------
    ss : StateSpace
        From :func:`~flexmb.state_space`.
    w : array_like, shape (n_w,), optional
        Angular frequencies, rad/s.
    f : array_like, shape (n_w,), optional
        Frequencies, Hz (instead of ``w``). Default (neither): ``n``
        log-spaced frequencies from a tenth of the slowest pole to ten times
        the fastest.
    pairs : sequence of (input, output), optional
        Names (or positions) of the pairs; default every input with every
        output.
    n : int
        Number of default frequencies.

    Returns
    -------
    FrequencyResponse
        ``.magnitude``, ``.phase`` (degrees), ``.response`` (complex), per
        pair, and ``.plot()`` (Bode diagram).

    Raises
    ------
    ModelError
        If both ``w`` and ``f`` are given, they are not a 1-d array of
        finite real numbers, a pair names an unknown signal, or there are
        more frequencies than
        :data:`~flexmb.analysis.statespace.MAX_FREQUENCIES` (or than fit in
        memory).

    Notes
    -----
    A is reduced to Hessenberg form once, so that each frequency costs one
    O(p^2) solve (Laub, IEEE Trans. Automat. Control 26 (1981) 407).

    Examples
    --------
    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    >>> pin = fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1))
    >>> system = m.add(pin, fm.JointSpringDamper("spring", pin, 3.0, 0.1)).build()
    >>> ss = fm.state_space(system, ["pin"], ["pin"])
    >>> fr = fm.frequency_response(ss, f=[0.1, 1.0, 10.0])
    >>> fr.phase[:, 0].round(1)  # resonance at 3 rad/s: 0, then -180 deg
    array([  -1.3, -176.5, -179.7])
    """
    if w is not None and f is not None:
        raise ModelError("frequency_response: give w (rad/s) or f (Hz), not both")
    if f is not None:
        w = 2 * np.pi * _frequencies("f", f)
    elif w is not None:
        w = _frequencies("w", w)
    else:
        n = whole("frequency_response", "n", n)
        _check_frequencies(n, 1, "frequency_response")
        w = _default_w(ss, n)
    if pairs is None:
        idx = [(i, o) for i in range(len(ss.inputs)) for o in range(len(ss.outputs))]
    else:
        idx = [(ss.index(i, "input"), ss.index(o, "output")) for i, o in pairs]
    H = ss.response(1j * w)
    response = np.stack([H[:, o, i] for i, o in idx], axis=1) if idx else np.zeros((w.shape[0], 0), complex)
    return FrequencyResponse(w=w, response=response, pairs=[(ss.inputs[i], ss.outputs[o]) for i, o in idx])
