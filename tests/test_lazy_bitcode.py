"""Cached kernels load without parsing their bitcode; a later compilation that links them still works.

:mod:`flexmb.kernels.lazy_bitcode` takes a loaded entry's defined symbols from
its object code instead of its bitcode, and parses the bitcode only when a new
compilation links the kernel in. The tests check that the two symbol sets are
the same on every shipped entry, and, in a new process with a warm cache, that
loading parses nothing, that a new kernel calling a loaded one (a user's
plugin kernel) and a loaded kernel's new signature compile and agree with the
loaded machine code, and that the bitcode is parsed once.
"""

from __future__ import annotations

import glob
import os
import pickle
import subprocess
import sys

import numpy as np
import pytest
from llvmlite import binding as ll

from flexmb.kernels import cache, lazy_bitcode, prebuilt
from flexmb.kernels.genalpha import _matvec


def _shipped_entries():
    if not prebuilt.usable(cache.sources_stamp()):
        pytest.skip("no usable shipped machine code on this branch (stale or another platform)")
    return sorted(glob.glob(os.path.join(prebuilt.folder(), "*.nbc")))


def test_object_code_defines_the_symbols_the_bitcode_defines():
    """On every shipped entry: numba's set (the bitcode's defined functions and globals) = the ELF symbol table's."""
    paths = _shipped_entries()
    assert len(paths) > 50
    for path in paths:
        with open(path, "rb") as f:
            name, kind, (object_code, bitcode) = pickle.loads(f.read())[0]
        assert kind == "object"
        module = ll.parse_bitcode(bitcode)
        from_bitcode = {g.name for group in (module.functions, module.global_variables) for g in group
                        if not g.is_declaration}
        assert lazy_bitcode.elf_defined_symbols(object_code) == from_bitcode, os.path.basename(path)


def test_not_an_elf_object_is_left_to_numba():
    assert lazy_bitcode.elf_defined_symbols(b"\xcf\xfa\xed\xfe" + bytes(60)) is None  # Mach-O
    assert lazy_bitcode.elf_defined_symbols(b"\x7fELF\x01\x01" + bytes(60)) is None  # 32-bit


#: in a new process: load _matvec from the cache, then compile a new kernel calling it and a new signature of it
LINK_AFTER_LOAD = r"""
import numpy as np
import numba
from llvmlite import binding as ll
from flexmb.kernels import lazy_bitcode
from flexmb.kernels.genalpha import _matvec

parses = []
parse = ll.parse_bitcode
ll.parse_bitcode = lambda data: parses.append(len(data)) or parse(data)

M = np.array([[1.0, 2.0], [3.0, 4.0]])
v = np.array([0.5, -1.25])
loaded = _matvec(M, v)
assert _matvec.stats.cache_hits, ("the kernel was compiled, not loaded", _matvec.stats)
library = _matvec.overloads[_matvec.signatures[0]].library
assert isinstance(library, lazy_bitcode.LazyLinkLibrary), type(library)
assert parses == [], parses

@numba.njit
def plugin(M, v):  # a user's kernel: links the loaded kernel's bitcode in
    return 2.0 * _matvec(M, v)

assert list(plugin(M, v)) == list(2.0 * loaded), (plugin(M, v), loaded)
assert len(parses) == 1, parses
assert list(plugin(M, v)) == list(2.0 * loaded)
assert len(parses) == 1, parses  # parsed once
assert list(_matvec(M.astype(np.float32), v.astype(np.float32))) == list(loaded)  # a new signature compiles
print("LOADED", list(loaded))
"""


def test_a_kernel_compiled_after_loading_links_the_loaded_one():
    M = np.array([[1.0, 2.0], [3.0, 4.0]])
    v = np.array([0.5, -1.25])
    expected = _matvec(M, v)  # compiled or loaded here: the entry is then in a cache the new process reads
    env = {k: val for k, val in os.environ.items() if k != "NUMBA_DISABLE_JIT"}
    out = subprocess.run([sys.executable, "-c", LINK_AFTER_LOAD], capture_output=True, text=True, env=env,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.split("LOADED ", 1)[1].strip() == str(list(expected))


def test_an_environment_is_rebuilt_without_importing_its_module():
    """numba's ``_rebuild_env`` less the import: an imported module's dict, else the name alone; memoized."""
    from numba.core import environment

    env = lazy_bitcode._rebuild_env("flexmb.kernels.cache", [1.5], "flexmb_test_env_imported")
    assert env.globals is cache.__dict__ and list(env.consts) == [1.5]
    assert environment.lookup_environment("flexmb_test_env_imported") is env
    env2 = lazy_bitcode._rebuild_env("flexmb_no_such_module", [], "flexmb_test_env_absent")
    assert env2.globals == {"__name__": "flexmb_no_such_module"} and "flexmb_no_such_module" not in sys.modules
    assert env2.can_cache() and env2.__reduce__()[1][0] == "flexmb_no_such_module"
    assert lazy_bitcode._rebuild_env("flexmb_no_such_module", [], "flexmb_test_env_absent") is env2


#: in a new process: B1 N = 8 simulated; which of numba's modules its loaded kernels' environments name it imported
ENV_MODULES = r"""
import json, sys
sys.path.insert(0, {bench!r})
import flexmb as fm
from flexmb.kernels import compiling
from scenes import b1
res = fm.simulate(b1(8).build(), 0.01, method="CVODE_BDF", n_out=2, progress=False)
assert res.status == "finished", res.status
from numba.core.runtime import rtsys
runtime_compiled = rtsys._init
imported = [m for m in {modules!r} if m in sys.modules]

import numba
import numpy as np

@numba.njit
def later(n):  # a compilation after the loads: numba's runtime (compiled now) and hash secrets (imported now)
    a = np.arange(n) * 2.0
    return a.sum() + (hash((n, 1.5)) != 0)

assert later(4) == 13.0 and rtsys._init
res2 = fm.simulate(b1(8).build(), 0.01, method="CVODE_BDF", n_out=2, progress=False)
assert res2.shape("beam")[-1, -1].tolist() == res.shape("beam")[-1, -1].tolist()
print(json.dumps({{"compiled": compiling.compile_seconds() > 0, "tip": res.shape("beam")[-1, -1].tolist(),
                  "imported": imported, "runtime_compiled": runtime_compiled}}))
"""


def test_a_run_with_a_warm_cache_imports_none_of_the_environments_modules():
    """Loading the kernels imports no numba module for its environments and compiles no runtime; compiling later works.

    numba.np.arrayobj, linalg, npyimpl named by the entries' environments;
    numba's runtime functions and hash secrets, which a compilation after the
    loads still gets.
    """
    import json

    bench = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
    modules = ["numba.np.arrayobj", "numba.np.linalg", "numba.np.npyimpl", "numba.cpython.unicode",
               "numba.cpython.hashing"]
    env = {k: val for k, val in os.environ.items() if k != "NUMBA_DISABLE_JIT"}
    runs = []
    for _ in range(2):  # the first may compile (kernels edited on a branch): the second loads
        out = subprocess.run([sys.executable, "-c", ENV_MODULES.format(bench=bench, modules=modules)],
                             capture_output=True, text=True, env=dict(env, OPENBLAS_NUM_THREADS="1"), timeout=900)
        assert out.returncode == 0, out.stderr[-3000:]
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    assert not runs[1]["compiled"]
    assert runs[1]["imported"] == [] and not runs[1]["runtime_compiled"]  # nor numba's runtime compiled
    assert runs[0]["tip"] == runs[1]["tip"]


#: in a new process: every symbol a shipped entry leaves undefined resolves once numba's context exists and
#: runtime_symbols ran, but for the runtime's compiled functions and the hash secrets, which rebuild installs
UNDEFINED_RESOLVE = r"""
import glob, json, os, pickle
from llvmlite import binding as ll
from numba.core.registry import cpu_target
from flexmb.kernels import lazy_bitcode, prebuilt

cpu_target.target_context.codegen()
lazy_bitcode.runtime_symbols()
left = set()
paths = sorted(glob.glob(os.path.join(prebuilt.folder(), "*.nbc")))
for path in paths:
    with open(path, "rb") as f:
        name, kind, (object_code, bitcode) = pickle.loads(f.read())[0]
    left |= {s for s in lazy_bitcode.elf_symbols(object_code)[1] if not ll.address_of_symbol(s)}
print(json.dumps([len(paths), sorted(left)]))
"""


def test_every_symbol_a_shipped_entry_uses_resolves_without_numbas_compiled_runtime():
    """The premise of loading without compiling numba's runtime: only its C functions are needed."""
    import json

    _shipped_entries()
    env = {k: val for k, val in os.environ.items() if k != "NUMBA_DISABLE_JIT"}
    out = subprocess.run([sys.executable, "-c", UNDEFINED_RESOLVE], capture_output=True, text=True, env=env,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    n, left = json.loads(out.stdout.strip().splitlines()[-1])
    assert n > 50
    assert [s for s in left if not s.startswith(("NRT_", "nrt_", "_numba_hashsecret_"))] == []


def test_elf_symbols_split_defined_and_undefined():
    paths = _shipped_entries()
    with open(paths[0], "rb") as f:
        name, kind, (object_code, bitcode) = pickle.loads(f.read())[0]
    defined, undefined = lazy_bitcode.elf_symbols(object_code)
    assert defined == lazy_bitcode.elf_defined_symbols(object_code) and not defined & undefined
    assert any(s.startswith("NRT_") for s in undefined) and any(s.startswith("Py") for s in undefined)
    assert lazy_bitcode.elf_symbols(b"\xcf\xfa\xed\xfe" + bytes(60)) is None


READY_FOR = r"""
import sys
from numba.core.registry import cpu_target
from numba.core.runtime import rtsys
from flexmb.kernels import lazy_bitcode

ctx = cpu_target.target_context
lazy_bitcode.runtime_symbols()
lazy_bitcode._ready_for(ctx, {"NRT_Allocate", "NRT_MemInfo_alloc_aligned", "PyTuple_New", "memset"})
assert not rtsys._init and "numba.cpython.hashing" not in sys.modules
lazy_bitcode._ready_for(ctx, {"_numba_hashsecret_siphash_k0"})
assert not rtsys._init and "numba.cpython.hashing" in sys.modules
lazy_bitcode._ready_for(ctx, {"NRT_Allocate", "nrt_unresolved_abort"})
assert rtsys._init
print("OK")
"""


def test_an_entry_using_the_runtimes_compiled_functions_or_hash_secrets_gets_them():
    env = {k: val for k, val in os.environ.items() if k != "NUMBA_DISABLE_JIT"}
    out = subprocess.run([sys.executable, "-c", READY_FOR], capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0 and out.stdout.strip() == "OK", out.stderr[-3000:]


#: in a new process: a kernel loaded from the cache; each environment its entry names is at its global's address
ENVS_SET = r"""
import ctypes
import numpy as np
from flexmb.kernels.genalpha import _matvec

_matvec(np.eye(2), np.ones(2))
assert _matvec.stats.cache_hits, ("compiled, not loaded", _matvec.stats)
cres = _matvec.overloads[_matvec.signatures[0]]
engine = cres.target_context.codegen()._engine
assert cres.referenced_envs
for env in cres.referenced_envs:
    assert ctypes.c_void_p.from_address(engine.get_global_value_address(env.env_name)).value == id(env)
print("ENVS", len(cres.referenced_envs))
"""


def test_a_loaded_kernels_environments_are_at_their_globals():
    M = np.array([[1.0, 2.0], [3.0, 4.0]])
    _matvec(M, np.ones(2))  # the entry in a cache the new process reads
    env = {k: val for k, val in os.environ.items() if k != "NUMBA_DISABLE_JIT"}
    out = subprocess.run([sys.executable, "-c", ENVS_SET], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0 and out.stdout.startswith("ENVS"), out.stderr[-3000:]
