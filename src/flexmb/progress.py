"""Progress of long runs (a simulation, a study): a tqdm bar in a terminal or a notebook, lines in a log.

Where the output goes decides how progress is shown:

* a terminal: a bar on stderr, with the elapsed and remaining time and the
  rate (``0.25 simulated s per wall-clock s``, never inverted, or cases per
  second), after the first half second;
* a notebook (Jupyter): tqdm's widget (``tqdm.auto``);
* a file or a pipe: one plain line every ``LOG_INTERVAL`` seconds, and
  none for a run shorter than that, so that a log holds no carriage
  returns and short runs add nothing;
* a CI job (the ``CI`` environment variable set): nothing.

Time spent compiling flexmb's kernels while a bar runs (a cold cache:
:mod:`flexmb.kernels.compiling` says so on one line) is taken off the
bar's clock: the bar appears only once they have compiled, and its rate and
remaining time count the simulation alone.
"""

from __future__ import annotations

import os
import shutil
import sys

from .kernels.compiling import compile_seconds

__all__ = ["Progress", "LOG_INTERVAL", "shown"]

#: seconds between two progress lines written to a file or a pipe (and before the first)
LOG_INTERVAL = 30.0


def shown(progress: bool | None) -> bool:
    """Whether to show progress: as asked, or by default everywhere but in a CI job.

    Parameters
    ----------
    progress : bool or None
        The caller's choice; None for the default.

    Returns
    -------
    bool
        True to show it.
    """
    if progress is not None:
        return bool(progress)
    return not os.environ.get("CI")


def _notebook() -> bool:
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    return shell is not None and type(shell).__name__ == "ZMQInteractiveShell"


#: the rate of a bar over simulated time (unit ``"s"``): tqdm's own reads ``s/s`` either way up (it inverts
#: rates below 1), so this one says which second is which, and is never inverted
SIM_RATE = "{:.3g} simulated s per wall-clock s"


def _rate_text(done: float, elapsed: float) -> str:
    """The rate of simulated time, :data:`SIM_RATE` (``?`` before any time has passed)."""
    return SIM_RATE.format(done / elapsed) if elapsed > 0 else SIM_RATE.replace("{:.3g}", "?")


def _sim_time_bar(base):
    """A tqdm class (terminal or notebook) whose bar format may use ``{sim_rate}``."""

    class Bar(base):
        @property
        def format_dict(self):
            d = super().format_dict
            d["sim_rate"] = _rate_text(d["n"] - d.get("initial", 0), d["elapsed"])
            return d

    return Bar


class _Lines:
    """A stream that turns tqdm's carriage-return updates into whole lines (for logs)."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, s: str) -> None:
        s = s.replace("\r", "").rstrip()
        if s:
            self.stream.write(s + "\n")

    def flush(self) -> None:
        self.stream.flush()


class Progress:
    """A progress bar over a quantity that grows to ``total`` (simulated time, cases).

    Parameters
    ----------
    total : float
        The amount at the end (s of simulated time, or a number of cases).
    what : str
        The label before the bar, e.g. ``"simulating"``.
    unit : str
        The unit of the amount: ``"s"`` for simulated time (the rate reads
        ``0.25 simulated s per wall-clock s``, whether above or below 1), or
        a count such as ``"cases"`` (``cases/s``, or ``s/cases`` below 1).
    enabled : bool
        False: nothing is shown (every method does nothing).
    initial : float
        The amount already done.

    Examples
    --------
    >>> bar = Progress(1.0, "simulating", "s", enabled=False)
    >>> bar.update_to(0.5)
    >>> bar.close()
    """

    def __init__(self, total: float, what: str, unit: str, enabled: bool = True, initial: float = 0.0):
        self._bar = None
        if not enabled:
            return
        self._compiled = compile_seconds()
        stream = sys.stderr
        if _notebook():
            from tqdm.auto import tqdm

            kw = {}
        else:
            from tqdm import tqdm

            tty = bool(getattr(stream, "isatty", lambda: False)())
            width = min(shutil.get_terminal_size((100, 20)).columns, 120)  # a terminal of size 0: 100
            kw = (dict(file=stream, delay=0.5, mininterval=0.2, ncols=width) if tty
                  else dict(file=_Lines(stream), delay=LOG_INTERVAL, mininterval=LOG_INTERVAL, ncols=100,
                            ascii=True))
        rate = "{rate_fmt}"
        if unit == "s":  # simulated time: tqdm's rate would read s/s both ways up
            tqdm, rate = _sim_time_bar(tqdm), "{sim_rate}"
        self._bar = tqdm(total=float(total), initial=float(initial), desc=what, unit=unit,
                         bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.4g}/{total:.4g} " + unit
                         + " [{elapsed}<{remaining}, " + rate + "{postfix}]", **kw)

    def update_to(self, amount: float) -> None:
        """Move the bar to ``amount`` done.

        Parameters
        ----------
        amount : float
            The amount done so far.
        """
        if self._bar is not None:
            self._skip_compilation()
            self._bar.update(float(amount) - self._bar.n)

    def _skip_compilation(self) -> None:
        """Move the bar's clock past the kernels' compilation since the last update (not shown, not timed)."""
        compiled = compile_seconds()
        if compiled > self._compiled:
            self._bar.start_t += compiled - self._compiled
            self._bar.last_print_t += compiled - self._compiled
            self._compiled = compiled

    @property
    def start_time(self) -> float | None:
        """The bar's start on tqdm's clock (:func:`time.time`), moved past any compilation seen so far.

        Returns
        -------
        float or None
            tqdm's start time, moved past compilation.
        """
        if self._bar is None:
            return None
        self._skip_compilation()
        return self._bar.start_t

    def note(self, text: str) -> None:
        """Show ``text`` after the counts (e.g. ``"2 failed"``).

        Parameters
        ----------
        text : str
            A short note.
        """
        if self._bar is not None:
            self._bar.set_postfix_str(text, refresh=False)

    def close(self) -> None:
        """End the bar (its last state stays on screen, the line ended)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
