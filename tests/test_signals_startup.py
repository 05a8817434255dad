"""Ctrl-C at unlucky moments of the ``flexmb`` command's start-up (issue #33, section 4).

A Ctrl-C while ``flexmb`` imported its modules printed a KeyboardInterrupt
traceback; one while llvmlite called back into Python as the compiled
kernels loaded was "ignored on calling ctypes callback function" (and the
command went on, or crashed). Each test delivers the signal at exactly that
moment, from inside the process (an import hook, a wrapped callback), and
runs the command through its console-script entry point, as the installed
``flexmb`` script does.
"""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import textwrap

import pytest

from conftest import with_default_signals

TUTORIALS = pathlib.Path(__file__).resolve().parents[1] / "tutorials"
PENDULUM = str(TUTORIALS / "01_pendulum.toml")

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")

ENTRY = textwrap.dedent("""
    import sys
    from importlib.metadata import entry_points
    (script,) = entry_points(group="console_scripts", name="flexmb")
    sys.argv = ["flexmb", *sys.argv[1:]]
    script.load()()
""")

#: sends the signal SIGNAL to the process when the module AT_MODULE is about to be imported
IMPORT_HOOK = textwrap.dedent("""
    import os, signal, sys
    class Interrupt:
        def find_spec(self, name, path=None, target=None):
            if name == os.environ["AT_MODULE"]:
                os.kill(os.getpid(), int(os.environ["SIGNAL"]))
            return None
    sys.meta_path.insert(0, Interrupt())
""")

DURING_IMPORT = IMPORT_HOOK + ENTRY

DURING_KERNEL_LOAD = textwrap.dedent("""
    import os, signal, time
    from numba.core import codegen
    hook = codegen.JITCodeLibrary._object_getbuffer_hook.__func__
    sent = []
    def interrupted(cls, ll_module):
        if not sent:
            sent.append(1)
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C inside llvmlite's callback
            time.sleep(0.05)
        return hook(cls, ll_module)
    codegen.JITCodeLibrary._object_getbuffer_hook = classmethod(interrupted)
""") + ENTRY


def _flexmb(code, tmp_path, *argv, **env):
    return subprocess.run(with_default_signals([sys.executable, "-c", code, *argv]), capture_output=True, text=True, cwd=tmp_path,
                          env=dict(os.environ, **env), timeout=600)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP], ids=lambda s: s.name)
@pytest.mark.parametrize("module", ["numba", "flexmb.integrators", "flexmb.scene"])
def test_a_signal_while_flexmb_imports_ends_it_with_one_line(tmp_path, sig, module):
    proc = _flexmb(DURING_IMPORT, tmp_path, "run", PENDULUM, "--out", "out", "--t-end", "0.1", "--quiet",
                   AT_MODULE=module, SIGNAL=str(int(sig)))
    assert proc.returncode == 128 + sig, (proc.returncode, proc.stderr[-3000:])
    assert proc.stderr.strip() == "flexmb: interrupted"  # main: a KeyboardInterrupt traceback, or killed
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("module", ["numba", "flexmb.scene"])
def test_python_m_flexmb_answers_a_signal_while_it_imports(tmp_path, module):
    """``python -m flexmb`` imports the package before its ``__main__``: the handler must already be there."""
    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(IMPORT_HOOK)
    path = os.pathsep.join([str(hook), *filter(None, [os.environ.get("PYTHONPATH")])])
    argv = [sys.executable, "-m", "flexmb", "run", PENDULUM, "--out", "out", "--t-end", "0.1", "--quiet"]
    proc = subprocess.run(with_default_signals(argv), capture_output=True, text=True, cwd=tmp_path, timeout=600,
                          env=dict(os.environ, PYTHONPATH=path, AT_MODULE=module, SIGNAL=str(int(signal.SIGINT))))
    assert proc.returncode == 130, (proc.returncode, proc.stderr[-3000:])
    assert proc.stderr.strip() == "flexmb: interrupted"  # before: a KeyboardInterrupt traceback
    assert not (tmp_path / "out").exists()


def test_ctrl_c_inside_llvmlites_callback_is_answered_after_it(tmp_path):
    proc = _flexmb(DURING_KERNEL_LOAD, tmp_path, "run", PENDULUM, "--out", "out", "--t-end", "100", "--quiet")
    assert proc.returncode == 130, (proc.returncode, proc.stderr[-3000:])
    # main: "Exception ignored on calling ctypes callback function" and the run went on to t_end (exit 0)
    assert "Exception ignored" not in proc.stderr and "Traceback" not in proc.stderr, proc.stderr[-3000:]
    assert "interrupted" in proc.stderr
