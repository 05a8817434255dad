"""Machine code shipped with the sources (issue #31): used when it fits, ignored otherwise, never in the way.

The shipped folder (:mod:`flexmb.kernels.prebuilt`) may be stale while
kernels are being edited: it is rebuilt as a session's last step, and
``.ci/run`` checks it (``python -m flexmb.kernels.prebuild --check``, tested
here on folders made here), not this suite. The mechanism is tested on a small
shipped folder made here: one kernel compiled for the x86-64-v3 baseline in
a process of its own, then loaded by processes whose CPU is the host's (a
different codegen key), with a read-only install, two at once, and with a
manifest that does not fit (another numba, a CPU without the baseline's
features, edited sources), which compiles with the usual one-line notice.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile

import llvmlite
import numba
import pytest
from numba.core.caching import UserProvidedCacheLocator

from flexmb.kernels import cache, prebuild, prebuilt

#: a small kernel, cheap to compile; prints whether it compiled in this process and whether anything was saved
PROBE = """
import os, sys
import numpy as np
import flexmb.kernels.prebuilt as prebuilt
prebuilt.ROOT = {root!r}
from flexmb.kernels.genalpha import _matvec
v = _matvec(np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([1.0, 1.0]))
assert list(v) == [3.0, 7.0], v
print("COMPILED", len(_matvec.stats.cache_misses), "LOADED", sum(_matvec.stats.cache_hits.values()))
"""


def _run(code, *, env=None, read_only=()):
    from test_kernel_cache import PRELUDE

    full = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_CPU", "NUMBA_CACHE_DIR", "FLEXMB_PREBUILT"))}
    full.update(env or {})
    return subprocess.run([sys.executable, "-c", PRELUDE % (list(read_only),) + code], env=full, capture_output=True,
                          text=True, timeout=600, cwd="/")


@pytest.fixture(scope="module")
def shipped():
    """A shipped folder holding ``genalpha._matvec`` for x86-64-v3 (made by the build's own collection step)."""
    top = tempfile.mkdtemp(prefix="flexmb-prebuilt-test-")
    os.chmod(top, 0o755)
    build_cache = os.path.join(top, "build-cache")
    env = {"NUMBA_CACHE_DIR": build_cache, "NUMBA_CPU_NAME": "x86-64-v3", "NUMBA_CPU_FEATURES": "",
           "FLEXMB_PREBUILT": "0"}
    out = _run(PROBE.format(root=os.path.join(top, "none")), env=env)
    assert out.returncode == 0 and "COMPILED 1" in out.stdout, out.stderr[-2000:]
    root = os.path.join(top, "root")
    folder = os.path.join(root, os.path.basename(prebuilt.folder()))
    os.makedirs(folder)
    filled = os.path.join(build_cache, UserProvidedCacheLocator.get_suitable_cache_subpath(
        os.path.join(cache.KERNELS, "genalpha.py")))
    manifest = prebuild.collect(filled, folder, cache.sources_stamp(), "x86-64-v3")
    assert manifest["magic_tuple"][1:] == ["x86-64-v3", ""]
    assert manifest["numba"] == numba.__version__ and manifest["llvmlite"] == llvmlite.__version__
    for dirpath, _, files in os.walk(root):  # as a root-owned install: readable, not writable
        for f in files:
            os.chmod(os.path.join(dirpath, f), 0o444)
        os.chmod(dirpath, 0o555)
    yield root
    for dirpath, _, _ in os.walk(top):
        os.chmod(dirpath, 0o755)
    shutil.rmtree(top, ignore_errors=True)


def _with_manifest(shipped, tmp_path, **changes):
    """A copy of the shipped folder whose manifest says something else."""
    root = tmp_path / "root"
    shutil.copytree(shipped, root)
    folder = root / os.path.basename(prebuilt.folder())
    os.chmod(folder, 0o755)
    path = folder / "manifest.json"
    manifest = json.loads(path.read_text())
    manifest.update(changes)
    os.chmod(path, 0o644)
    path.write_text(json.dumps(manifest))
    return str(root)


def test_a_fresh_shipped_folder_passes_the_check(shipped):
    assert prebuild.check(shipped) == []


@pytest.mark.parametrize("changes, why", [
    ({"stamp": "0" * 64}, "built from other kernel sources than these"),
    ({"numba": "0.0.1"}, f"built for numba 0.0.1, this environment has {numba.__version__}"),
    ({"llvmlite": "0.0.2"}, f"built for llvmlite 0.0.2, this environment has {llvmlite.__version__}"),
    ({"kernels": []}, "holds other files than its manifest lists"),
])
def test_a_stale_shipped_folder_fails_the_check_naming_the_rebuild(shipped, tmp_path, monkeypatch, changes, why):
    root = _with_manifest(shipped, tmp_path, **changes)
    problems = prebuild.check(root)
    assert len(problems) == 1 and problems[0].startswith(os.path.join(root, os.path.basename(prebuilt.folder())))
    assert why in problems[0], problems
    monkeypatch.setattr(prebuilt, "ROOT", root)
    with pytest.raises(SystemExit) as stop:
        prebuild.main(["--check"])
    assert why in str(stop.value) and prebuild.REBUILD in str(stop.value), stop.value


def test_another_interpreters_folder_is_checked_against_the_sources_only(shipped, tmp_path):
    root = tmp_path / "root"
    path = root / "cpython-399-x86_64-linux"
    shutil.copytree(os.path.join(shipped, os.path.basename(prebuilt.folder())), path)
    os.chmod(path, 0o755)
    manifest = json.loads((path / "manifest.json").read_text())
    os.chmod(path / "manifest.json", 0o644)
    (path / "manifest.json").write_text(json.dumps(dict(manifest, numba="0.0.1")))
    assert prebuild.check(str(root)) == []
    (path / "manifest.json").write_text(json.dumps(dict(manifest, stamp="0" * 64)))
    assert ["built from other kernel sources" in p for p in prebuild.check(str(root))] == [True]


def test_ci_checks_the_shipped_folder():
    """The freshness check is a step of .ci/run (the README's test command does not fail on a stale folder)."""
    with open(os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), ".ci", "run")) as f:
        assert "\npython -m flexmb.kernels.prebuild --check\n" in f.read()


def test_a_read_only_install_loads_the_shipped_code_for_another_cpu_and_says_nothing(shipped):
    """No writable cache anywhere (root-owned sources, no home): the kernel loads from the shipped folder."""
    read_only = [os.path.dirname(cache.KERNELS), shipped, "/nonexistent-home"]
    out = _run(PROBE.format(root=shipped), env={"HOME": "/nonexistent-home", "XDG_CACHE_HOME": "/nonexistent-home/c"},
               read_only=read_only)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "COMPILED 0 LOADED 1" in out.stdout, (out.stdout, out.stderr[-2000:])
    assert out.stderr.strip() == "", out.stderr


def test_two_processes_on_a_cold_cache_both_load_the_shipped_code(shipped, tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    env = {k: v for k, v in env.items() if not k.startswith(("NUMBA_CPU", "FLEXMB_PREBUILT"))}
    procs = [subprocess.Popen([sys.executable, "-c", PROBE.format(root=shipped)], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, cwd="/") for _ in range(2)]
    for p in procs:
        out, err = p.communicate(timeout=600)
        assert p.returncode == 0 and "COMPILED 0 LOADED 1" in out, err[-2000:]
    saved = [f for _, _, files in os.walk(tmp_path / "cache") for f in files]
    assert not any(f.startswith("genalpha._matvec") for f in saved), saved


@pytest.mark.parametrize("changes, why", [
    ({"numba": "0.0.1"}, f"the shipped machine code is for numba 0.0.1, this is {numba.__version__}"),
    ({"features": ["sse2", "no-such-feature"]}, "this CPU lacks no-such-feature"),
    ({"stamp": "0" * 64}, "the shipped machine code predates an edit of the kernels"),
])
def test_shipped_code_that_does_not_fit_compiles_with_one_notice_saying_why(shipped, tmp_path, changes, why):
    root = _with_manifest(shipped, tmp_path, **changes)
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    runs = [_run(PROBE.format(root=root), env=env) for _ in range(2)]
    for out in runs:
        assert out.returncode == 0, out.stderr[-2000:]
    assert "COMPILED 1 LOADED 0" in runs[0].stdout, runs[0].stdout
    notices = runs[0].stderr.strip().splitlines()
    assert len(notices) == 1 and notices[0].startswith("flexmb: compiling flexmb's kernels") and why in notices[0], (
        runs[0].stderr)
    assert "COMPILED 0 LOADED 1" in runs[1].stdout and runs[1].stderr.strip() == "", runs[1].stderr  # its own cache


def test_a_damaged_shipped_entry_is_a_miss(shipped, tmp_path):
    root = tmp_path / "root"
    shutil.copytree(shipped, root)
    folder = root / os.path.basename(prebuilt.folder())
    for name in os.listdir(folder):
        if name.endswith(".nbc"):
            os.chmod(folder / name, 0o644)
            (folder / name).write_bytes(b"\x80\x04truncated")
    out = _run(PROBE.format(root=str(root)), env={"NUMBA_CACHE_DIR": str(tmp_path / "cache")})
    assert out.returncode == 0, out.stderr[-2000:]
    assert "COMPILED 1 LOADED 0" in out.stdout and "Traceback" not in out.stderr, out.stderr


def test_user_chosen_machine_code_is_not_replaced_by_the_shipped_one(shipped, tmp_path):
    out = _run(PROBE.format(root=shipped), env={"NUMBA_CACHE_DIR": str(tmp_path / "cache"), "NUMBA_CPU_NAME": "generic"})
    assert out.returncode == 0, out.stderr[-2000:]
    assert "COMPILED 1 LOADED 0" in out.stdout and "NUMBA_CPU_NAME" in out.stderr, out.stderr
