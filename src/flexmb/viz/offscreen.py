"""Off-screen pyvista plotters that do not try a display that is not there.

VTK's Linux wheels (9.4 on) choose their OpenGL window when a render
window is created: X first, then EGL, then OSMesa. Without an X server
the X attempt fails and logs ``bad X server connection. DISPLAY=`` on
stderr before EGL takes over, once per process. :func:`offscreen_plotter`
skips the attempt where it cannot succeed (no ``DISPLAY``) by asking VTK
for its EGL window, through ``VTK_DEFAULT_OPENGL_WINDOW``, for the
creation of that plotter only; VTK still falls back to OSMesa on its own if
EGL cannot be loaded. A ``VTK_DEFAULT_OPENGL_WINDOW`` set by the user is
left alone, as is every system with a display.
"""

from __future__ import annotations

import contextlib
import os
import sys

from ..errors import ExportError

__all__ = ["offscreen_plotter"]

#: VTK reads this when it creates a render window (``vtkOpenGLRenderWindow::New``)
WINDOW_VARIABLE = "VTK_DEFAULT_OPENGL_WINDOW"
#: the window VTK is asked for where there is no display (it falls back to OSMesa without EGL)
HEADLESS_WINDOW = "vtkEGLRenderWindow"


def _pyvista():
    try:
        import pyvista as pv
    except ImportError as exc:
        raise ExportError("rendering needs pyvista: pip install 'flexmb[viz]'") from exc
    return pv


def headless_window() -> str | None:
    """The OpenGL window to ask VTK for here: EGL on Linux without a display, else None (VTK's choice).

    Returns
    -------
    str or None
        ``'vtkEGLRenderWindow'`` on Linux without ``DISPLAY`` when the
        user has not set ``VTK_DEFAULT_OPENGL_WINDOW``; else None.
    """
    if not sys.platform.startswith("linux") or os.environ.get("DISPLAY") or os.environ.get(WINDOW_VARIABLE):
        return None
    return HEADLESS_WINDOW


@contextlib.contextmanager
def _window_choice(window: str | None):
    """Set ``VTK_DEFAULT_OPENGL_WINDOW`` to ``window`` for the block (nothing if None), then remove it."""
    if window is None:
        yield
        return
    os.environ[WINDOW_VARIABLE] = window
    try:
        yield
    finally:
        os.environ.pop(WINDOW_VARIABLE, None)


def offscreen_plotter(**kwargs):
    """A ``pyvista.Plotter`` that renders off-screen, without VTK's display warning where there is none.

    Parameters
    ----------
    **kwargs
        Keyword arguments of ``pyvista.Plotter`` (``window_size``,
        ``shape``, ...); ``off_screen`` is always True.

    Returns
    -------
    pyvista.Plotter
        The plotter; close it when done.

    Raises
    ------
    ExportError
        If pyvista is not installed (``pip install 'flexmb[viz]'``).

    Notes
    -----
    On Linux without ``DISPLAY`` the plotter's window is VTK's EGL window
    (OSMesa where EGL is missing), so VTK does not first try X and log
    ``bad X server connection``; see ``docs/export.md``.

    Examples
    --------
    >>> from flexmb.viz import offscreen_plotter
    >>> plotter = offscreen_plotter(window_size=(320, 240))  # doctest: +SKIP
    """
    pv = _pyvista()
    kwargs["off_screen"] = True
    with _window_choice(headless_window()):
        return pv.Plotter(**kwargs)
