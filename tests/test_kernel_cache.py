"""The kernels' cache never stops flexmb (issue #33, section 2).

flexmb must import and run with no writable home, with a read-only warm
cache (a root-owned install, a read-only ``NUMBA_CACHE_DIR``) and after a
crash left a damaged cache file; and a kernel's cached machine code must go
stale when any kernel source changes (a kernel inlines kernels of other
files). The subprocess tests that act as an unprivileged user need root to
become one (as in CI), and skip with that reason otherwise.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import pytest

from flexmb.kernels import cache
from flexmb.kernels.genalpha import _matvec

#: a small kernel, cheap to compile, called directly from Python
PROBE = ("import numpy as np; from flexmb.kernels.genalpha import _matvec; "
         "from flexmb.kernels.cache import cache_locations; "
         "v = _matvec(np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([1.0, 1.0])); "
         "assert list(v) == [3.0, 7.0], v; print('LOCATION', cache_locations()['genalpha._matvec'])")



def _warm():
    """The probe kernel's entry saved by a process of its own (in the cache folder :func:`_run`'s processes use:
    ``__pycache__`` beside the sources, whatever ``NUMBA_CACHE_DIR`` the tests run with); its index path."""
    out = _run(PROBE)
    assert out.returncode == 0, out.stderr[-2000:]
    folder = out.stdout.split("LOCATION ", 1)[1].strip()
    index = os.path.join(folder, os.path.basename(_matvec._cache._cache_file._index_path))
    assert os.path.exists(index), index
    return index


#: prints whether the probe kernel's index in :func:`_run`'s cache folder loads (holds entries for today's sources)
INDEX_LOADS = ("from flexmb.kernels.genalpha import _matvec; "
               "print('INDEX', bool(_matvec._cache._cache_file._load_index()))")


#: run first in a subprocess: the folders in READ_ONLY refuse every write, as a read-only install, a cache
#: folder of another user or a missing home do (also when the tests run as root, who could write anywhere)
PRELUDE = """
import builtins, os, tempfile
READ_ONLY = [os.path.abspath(p) for p in %r]
def _ro(path):
    try:
        path = os.path.abspath(os.fsdecode(path))
    except TypeError:
        return False
    return any(path == r or path.startswith(r + os.sep) for r in READ_ONLY)
def _refuse(path):
    raise PermissionError(13, "Read-only folder", str(path))
_tf, _mk, _open = tempfile.TemporaryFile, os.makedirs, builtins.open
def TemporaryFile(*a, dir=None, **k):
    if dir is not None and _ro(dir):
        _refuse(dir)
    return _tf(*a, dir=dir, **k)
def makedirs(path, *a, **k):
    if _ro(path) and not os.path.isdir(path):
        _refuse(path)
    return _mk(path, *a, **k)
def open(file, mode="r", *a, **k):
    if isinstance(file, (str, bytes, os.PathLike)) and any(c in mode for c in "wax+") and _ro(file):
        _refuse(file)
    return _open(file, mode, *a, **k)
tempfile.TemporaryFile, os.makedirs, builtins.open = TemporaryFile, makedirs, open
"""


def _run(code, *, env=None, read_only=(), timeout=300):
    """``code`` in a new process, after :data:`PRELUDE`; the shipped machine code not used (this file tests the cache
    folders; tests/test_prebuilt.py the shipped code)."""
    full = dict(os.environ, FLEXMB_PREBUILT="0", **(env or {}))
    full.pop("NUMBA_CACHE_DIR", None) if not (env or {}).get("NUMBA_CACHE_DIR") else None
    return subprocess.run([sys.executable, "-c", PRELUDE % (list(read_only),) + code], env=full, capture_output=True,
                          text=True, timeout=timeout, cwd="/")


#: a home that does not exist (and that the prelude keeps from being created)
NO_HOME = {"HOME": "/nonexistent-home", "XDG_CACHE_HOME": "/nonexistent-home/.cache"}


def test_the_stamp_covers_every_kernel_source(tmp_path):
    """A change in any kernel file (a callee of another file's kernel) makes every entry stale."""
    for name in ("tree.py", "loops.py", "__init__.py"):
        shutil.copy(os.path.join(cache.KERNELS, name), tmp_path / name)
    before = cache.sources_stamp(str(tmp_path))
    with open(tmp_path / "loops.py", "a") as f:
        f.write("\n# a callee changed\n")
    cache.sources_stamp.cache_clear()
    assert cache.sources_stamp(str(tmp_path)) != before
    shutil.copy(os.path.join(cache.KERNELS, "cache.py"), tmp_path / "cache.py")  # holds no kernel: not stamped
    cache.sources_stamp.cache_clear()
    stamp = cache.sources_stamp(str(tmp_path))
    with open(tmp_path / "cache.py", "a") as f:
        f.write("\n# not a kernel\n")
    cache.sources_stamp.cache_clear()
    assert cache.sources_stamp(str(tmp_path)) == stamp


@pytest.mark.parametrize("damage", ["truncated index", "empty data", "random data"])
def test_a_damaged_entry_is_a_miss_and_is_rewritten(damage):
    index = _warm()
    data = sorted(f for f in os.listdir(os.path.dirname(index))
                  if f.startswith(os.path.basename(index)[:-4]) and f.endswith(".nbc"))
    assert data
    if damage == "truncated index":
        os.truncate(index, 20)
    else:
        with open(os.path.join(os.path.dirname(index), data[0]), "wb") as f:
            f.write(b"" if damage == "empty data" else np.random.default_rng(1).bytes(300))
    out = _run(PROBE)
    assert out.returncode == 0, out.stderr[-2000:]
    again = _run(PROBE)  # the entry was rewritten whole: the next run loads it
    assert again.returncode == 0, again.stderr[-2000:]
    index_loads = _run(INDEX_LOADS)
    assert "INDEX True" in index_loads.stdout, ("the index was not rewritten", index_loads.stderr[-2000:])


def test_no_home_and_a_read_only_install_use_the_warm_cache_read_only():
    index = _warm()
    out = _run(PROBE, env=NO_HOME, read_only=[os.path.dirname(cache.KERNELS), "/nonexistent-home"])
    assert out.returncode == 0, out.stderr[-2000:]
    assert f"LOCATION {os.path.dirname(index)}" in out.stdout, out.stdout
    assert "Traceback" not in out.stderr


@pytest.fixture
def shared_tmp():
    """A folder other users can read (pytest's own tmp_path is private to its user)."""
    path = tempfile.mkdtemp(prefix="flexmb-cache-test-")
    os.chmod(path, 0o755)
    yield path
    shutil.rmtree(path, ignore_errors=True)


def test_a_read_only_numba_cache_dir_holding_a_warm_cache_is_used(shared_tmp):
    from numba.core.caching import UserProvidedCacheLocator

    index = _warm()
    top = os.path.join(shared_tmp, "cache")
    sub = os.path.join(top, UserProvidedCacheLocator.get_suitable_cache_subpath(_matvec.py_func.__code__.co_filename))
    os.makedirs(sub)
    stem = os.path.basename(index)[:-4]
    for f in os.listdir(os.path.dirname(index)):
        if f.startswith(stem):
            shutil.copy(os.path.join(os.path.dirname(index), f), os.path.join(sub, f))
            os.chmod(os.path.join(sub, f), 0o444)
    for p in (top, sub):
        os.chmod(p, 0o555)
    try:
        out = _run(PROBE, env=dict(NO_HOME, NUMBA_CACHE_DIR=top),
                   read_only=[top, os.path.dirname(cache.KERNELS), "/nonexistent-home"])
    finally:
        for p in (top, sub):
            os.chmod(p, 0o755)
    assert out.returncode == 0, out.stderr[-2000:]
    assert f"LOCATION {sub}" in out.stdout, out.stdout


USER_KERNELS = """
from flexmb.kernels.cache import njit


@njit(cache=True)
def twice(x):
    return 2.0 * x


@njit(cache=True)
def thrice(x):
    return 3.0 * x
"""


def test_nowhere_to_cache_compiles_in_memory_with_one_notice(shared_tmp):
    """No folder can hold a new kernel's cache: no home, a read-only source folder, no temporary folder."""
    with open(os.path.join(shared_tmp, "userkern.py"), "w") as f:
        f.write(USER_KERNELS)
    os.chmod(os.path.join(shared_tmp, "userkern.py"), 0o644)
    code = ("import sys; tempfile.tempdir = '/nonexistent-tmp'; sys.path.insert(0, %r); "
            "import userkern; print('RESULT', userkern.twice(1.5) + userkern.thrice(1.0))" % shared_tmp)
    out = _run(code, env=NO_HOME, read_only=[shared_tmp, "/nonexistent-home", "/nonexistent-tmp"])
    assert out.returncode == 0, out.stderr[-2000:]
    assert "RESULT 6.0" in out.stdout
    notices = [line for line in out.stderr.splitlines() if line.startswith("flexmb:")]
    assert len(notices) == 1 and "compiling them in memory" in notices[0], out.stderr
    assert "Traceback" not in out.stderr
    assert not os.path.exists(os.path.join(shared_tmp, "__pycache__"))


def test_no_home_caches_new_kernels_in_a_private_temporary_folder(shared_tmp):
    """No writable home and a read-only source folder: a per-user folder under the temporary directory."""
    src, tmp = os.path.join(shared_tmp, "src"), os.path.join(shared_tmp, "tmp")
    os.makedirs(src)
    os.makedirs(tmp)
    with open(os.path.join(src, "userkern.py"), "w") as f:
        f.write(USER_KERNELS)
    code = ("import sys; tempfile.tempdir = %r; sys.path.insert(0, %r); "
            "import userkern; print('RESULT', userkern.twice(2.0))" % (tmp, src))
    runs = [_run(code, env=NO_HOME, read_only=[src, "/nonexistent-home"]) for _ in range(2)]
    for out in runs:  # the second loads what the first saved
        assert out.returncode == 0, out.stderr[-2000:]
        assert "RESULT 4.0" in out.stdout
    assert "no writable cache folder" in runs[0].stderr and "Traceback" not in runs[0].stderr
    private = os.path.join(tmp, f"flexmb-numba-{os.getuid()}")
    assert oct(os.stat(private).st_mode & 0o777) == oct(0o700)
    saved = [f for _, _, files in os.walk(private) for f in files]
    assert any(f.startswith("userkern.twice") and f.endswith(".nbi") for f in saved), saved


def test_two_processes_compiling_into_one_cold_cache_both_finish(shared_tmp):
    """Two runs start at once on an empty cache: both compile, both save, neither fails nor damages it."""
    src, cache_dir = os.path.join(shared_tmp, "src"), os.path.join(shared_tmp, "cache")
    os.makedirs(src)
    with open(os.path.join(src, "userkern.py"), "w") as f:
        f.write(USER_KERNELS)
    code = ("import sys; sys.path.insert(0, %r); import userkern; "
            "print('RESULT', userkern.twice(2.0) + userkern.thrice(2.0))" % src)
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    procs = [subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, cwd="/") for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    for p, (out, err) in zip(procs, outs):
        assert p.returncode == 0 and "RESULT 10.0" in out, err[-2000:]
    again = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300, cwd="/")
    assert again.returncode == 0 and "RESULT 10.0" in again.stdout, again.stderr[-2000:]
    saved = [f for _, _, files in os.walk(cache_dir) for f in files]
    assert sum(f.endswith(".nbi") for f in saved) == 2 and not any(".tmp." in f for f in saved), saved


def test_a_kernels_cache_is_located_at_its_first_use():
    """Making a kernel's cache chooses no folder (numba writes a probe file there): its first use does."""
    def probe(x):
        return x

    kc = cache.KernelCache(probe)
    assert "_impl" not in vars(kc) and "_cache_file" not in vars(kc)
    assert kc._impl.locator.get_cache_path() == kc._cache_path  # the first read locates it
    assert kc._enabled and "_lazy_py_func" not in vars(kc)
    with pytest.raises(AttributeError):
        kc.no_such_attribute
