"""Viewer pages in headless Chromium: screenshots and the page's DOM after its script ran.

Used by the browser test of the viewer (``tests/test_viewer_browser.py``)
and by ``docs/figures/wiper_viewer.py``. Chromium is found on the PATH
(Debian's ``chromium`` package, or Google Chrome); each call runs it in
its own process group with a throw-away profile and ends that group when
done, so that no browser process is left behind.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import tempfile
from pathlib import Path

from .._files import atomic_write
from ..errors import ExportError

__all__ = ["find_chromium", "screenshot", "dom"]

_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")


def find_chromium() -> str | None:
    """The path of a Chromium (or Chrome) executable on the PATH, or None."""
    for name in _NAMES:
        found = shutil.which(name)
        if found:
            return found
    return None


def _run(page, fragment: str, flags: list[str], browser: str | None, timeout: float) -> str:
    """Run the browser headless on the page (with ``#fragment``); return its standard output."""
    browser = browser or find_chromium()
    if browser is None:
        raise ExportError("no Chromium on the PATH (Debian: apt-get install chromium)")
    url = Path(os.fspath(page)).resolve().as_uri() + (f"#{fragment}" if fragment else "")
    with tempfile.TemporaryDirectory(prefix="flexmb_chromium_") as profile:
        args = [browser, "--headless", "--disable-gpu", "--hide-scrollbars", "--no-first-run",
                "--no-default-browser-check", "--disable-extensions", f"--user-data-dir={profile}",
                "--virtual-time-budget=3000", *flags, url]
        if hasattr(os, "geteuid") and os.geteuid() == 0:  # Chromium's sandbox refuses to run as root
            args.insert(1, "--no-sandbox")
        proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                start_new_session=True)
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            out, err = "", f"no answer within {timeout} s"
        finally:
            try:  # the browser's helper processes too: its whole group
                os.killpg(proc.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            proc.wait()
    if proc.returncode not in (0, -signal.SIGKILL) or err.startswith("no answer"):
        raise ExportError(f"{browser} failed on {url}: {err.strip()[-500:]}")
    return out


def screenshot(page, png, fragment: str = "", *, window_size=(900, 600), browser: str | None = None,
               timeout: float = 120.0) -> Path:
    """Screenshot of a viewer page in headless Chromium.

    Parameters
    ----------
    page : str or path-like
        The HTML file.
    png : str or path-like
        The PNG to write (whole or not at all).
    fragment : str
        The URL fragment: the viewer's state, e.g. ``"frame=10&color=von_mises"``.
    window_size : tuple of int
        Width and height, pixels.
    browser : str, optional
        The browser executable (default: :func:`find_chromium`).
    timeout : float
        Seconds to wait for the browser.

    Returns
    -------
    pathlib.Path
        ``png``.

    Raises
    ------
    ExportError
        If there is no browser, it fails or writes no picture.
    """
    with tempfile.TemporaryDirectory(prefix="flexmb_shot_") as tmp:
        shot = Path(tmp) / "shot.png"
        w, h = (int(v) for v in window_size)
        _run(page, fragment, [f"--window-size={w},{h}", f"--screenshot={shot}"], browser, timeout)
        if not shot.is_file() or shot.stat().st_size == 0:
            raise ExportError(f"the browser wrote no screenshot of {page}")
        return atomic_write(Path(os.fspath(png)), lambda t: shutil.copyfile(shot, t), suffix=".png")


def dom(page, fragment: str = "", *, browser: str | None = None, timeout: float = 120.0) -> str:
    """The page's DOM, serialised, once its script has run (Chromium's ``--dump-dom``).

    Parameters
    ----------
    page : str or path-like
        The HTML file.
    fragment : str
        The URL fragment (the viewer's state).
    browser : str, optional
        The browser executable (default: :func:`find_chromium`).
    timeout : float
        Seconds to wait for the browser.

    Returns
    -------
    str
        The DOM as HTML.

    Raises
    ------
    ExportError
        If there is no browser or it fails.
    """
    return _run(page, fragment, ["--dump-dom"], browser, timeout)
