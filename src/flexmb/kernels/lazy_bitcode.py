"""Cached machine code made ready to run without parsing its bitcode: the parse waits until a compilation links it.

A numba cache entry holds a kernel's object code and its LLVM bitcode.
numba's loader (``JITCodeLibrary._unserialize``) parses the bitcode into an
LLVM module at once, for two uses: the names of the symbols the object
defines (numba's execution engine looks a symbol up only if it knows it is
defined), and a module to link into a *later* compilation that calls the
kernel (a user's plugin kernel that calls flexmb's, a new signature). A run
that only calls loaded kernels needs neither module; parsing them is most of
the cost of loading the kernels (``benchmarks/startup.py --breakdown``,
``of_it_parse_bitcode_s``).

:func:`rebuild` loads an entry as numba does, with two differences:

* the defined symbols are read from the object code's ELF symbol table (the
  same set the bitcode's defined functions and globals give: checked on every
  shipped entry by the tests);
* the library is a :class:`LazyLinkLibrary`, which keeps the bitcode as
  bytes and parses it on the first link into a later compilation.

Entries it cannot treat so (not object code, object code that is not ELF,
another codegen's library class) are loaded by numba's own code.

:func:`load_entry` reads an entry's payload as numba does (``pickle``), with
one difference: the environments of the numba functions linked into the
kernel (numba's ``np.empty``, array and math implementations, ...) are
rebuilt without importing the modules that define them
(``numba.np.arrayobj``, ``numba.np.linalg``, ``numba.np.npyimpl``, ...: a
large part of a short run's first load). numba's loader imports each module
only to keep its dictionary as the environment's ``globals``, which only
object-mode code reads; flexmb's kernels and the numba functions they call
are nopython code, which reads an environment's constants only. Where the
module is imported already its dictionary is used, as numba does; else the
environment's globals hold the module's name alone (what numba's
``Environment.__reduce__`` and ``can_cache`` read).
"""

from __future__ import annotations

import ctypes
import io
import pickle
import struct
import sys

from llvmlite import binding as ll
from numba.core import compiler, environment
from numba.core.codegen import JITCodeLibrary

__all__ = ["LazyLinkLibrary", "rebuild", "elf_defined_symbols", "elf_symbols", "load_entry", "runtime_symbols"]

#: ELF symbol types that name no function or variable (STT_SECTION, STT_FILE)
_NO_SYMBOL_TYPES = (3, 4)


def elf_defined_symbols(obj: bytes) -> set[str] | None:
    """The names of the symbols an ELF64 little-endian object file defines, None if it is not one.

    Parameters
    ----------
    obj : bytes
        The object code (a relocatable ELF file, as numba caches it on Linux).

    Returns
    -------
    set of str or None
        Every named symbol with a section (functions and variables, local or
        global), as numba's ``JitEngine._load_defined_symbols`` collects them
        from the module's definitions.
    """
    symbols = elf_symbols(obj)
    return None if symbols is None else symbols[0]


def elf_symbols(obj: bytes) -> tuple[set[str], set[str]] | None:
    """The symbols an ELF64 little-endian object file defines and those it uses undefined, None if it is not one.

    Parameters
    ----------
    obj : bytes
        The object code.

    Returns
    -------
    tuple of two sets of str, or None
        ``(defined, undefined)``: :func:`elf_defined_symbols`'s set, and
        the named symbols without a section (what the linker must resolve:
        the C API, numba's C helpers, its runtime's functions, libm).
    """
    if obj[:4] != b"\x7fELF" or obj[4:6] != b"\x02\x01":  # 64-bit, little-endian
        return None
    shoff, = struct.unpack_from("<Q", obj, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", obj, 0x3A)
    sections = [struct.unpack_from("<IIQQQQIIQQ", obj, shoff + i * shentsize) for i in range(shnum)]
    defined, undefined = set(), set()
    for _, sh_type, _, _, offset, size, link, _, _, _ in sections:
        if sh_type != 2:  # SHT_SYMTAB
            continue
        strings = sections[link][4]
        for st_name, st_info, _, st_shndx, _, _ in struct.iter_unpack("<IBBHQQ", obj[offset:offset + size]):
            if not st_name or st_info & 0xF in _NO_SYMBOL_TYPES:
                continue
            start = strings + st_name
            (undefined if st_shndx == 0 else defined).add(obj[start:obj.index(b"\0", start)].decode())
    return defined, undefined


def runtime_symbols() -> None:
    """Make numba's runtime C functions known to LLVM's linker (``NRT_Allocate``, ``NRT_MemInfo_alloc``, ...).

    This is the first half of numba's ``rtsys.initialize``; the second half
    compiles the runtime's LLVM functions (``NRT_incref``, ``NRT_decref``,
    atomic counters), which a compilation links into every library it
    makes: cached machine code defines its own copies and needs only the C
    functions. numba initializes its runtime fully before a compilation
    (``CPUContext.load_additional_registries``) and :func:`rebuild` before
    loading an entry that refers to one of those functions undefined.
    """
    global _runtime_symbols_added
    if _runtime_symbols_added:
        return
    from numba.core import config
    from numba.core.runtime import _nrt_python

    if config.NRT_STATS:
        _nrt_python.memsys_enable_stats()
    for py_name, address in _nrt_python.c_helpers.items():
        ll.add_symbol(py_name if py_name.startswith("_") else "NRT_" + py_name, address)
    _runtime_symbols_added = True


_runtime_symbols_added = False


def _ready_for(target_context, undefined) -> None:
    """Install what an object's undefined symbols need beyond :func:`runtime_symbols`.

    The runtime's compiled LLVM functions (numba's full ``rtsys.initialize``)
    where it uses one of them, and the hash secrets' symbols (installed by
    importing ``numba.cpython.hashing``) where it reads them.
    """
    from numba.core.runtime import _nrt_python, rtsys

    c_functions = {name if name.startswith("_") else "NRT_" + name for name in _nrt_python.c_helpers}
    if not rtsys._init and any(s.startswith(("NRT_", "nrt_")) and s not in c_functions for s in undefined):
        rtsys.initialize(target_context)
    if any(s.startswith("_numba_hashsecret_") for s in undefined):
        import numba.cpython.hashing  # noqa: F401 - installs the hash secrets' symbols


class LazyLinkLibrary(JITCodeLibrary):
    """The JIT code library (numba's) of a cached entry, its bitcode parsed only when a compilation links it in.

    Parameters
    ----------
    codegen : JITCPUCodegen
        numba's code generator of this process.
    name : str
        The library's name (the entry's).
    """

    #: the entry's bitcode, until it is parsed
    _bitcode: bytes | None = None

    def _get_module_for_linking(self):
        """The module a later compilation links in: the bitcode, parsed on the first call."""
        if self._shared_module is None and self._bitcode is not None:
            self._shared_module = ll.parse_bitcode(self._bitcode)
            self._bitcode = None
        return super()._get_module_for_linking()


def _library(target_context, libdata):
    """A cached library made ready to run (its bitcode unparsed), or None where numba's own loader must do it."""
    codegen = target_context.codegen()
    name, kind, data = libdata
    if kind != "object" or codegen._library_class is not JITCodeLibrary:
        return None
    object_code, bitcode = data
    symbols = elf_symbols(object_code)
    if symbols is None:
        return None
    defined, undefined = symbols
    return lambda: _ready_for(target_context, undefined) or _ready(codegen, name, object_code, bitcode, defined)


def _ready(codegen, name, object_code, bitcode, symbols):
    """What numba's ``JITCodeLibrary._unserialize`` does with object code, minus the bitcode's parse."""
    library = LazyLinkLibrary(codegen, name)
    library.enable_object_caching()
    library._set_compiled_object(object_code)
    library._bitcode = bitcode
    library._finalize_final_module()
    codegen._engine._defined_symbols |= symbols
    return library


def rebuild(target_context, libdata, fndesc, env, signature, objectmode, lifted, typeann, reload_init,
            referenced_envs):
    """The compile result of a cache entry's payload: numba's ``CompileResult._rebuild``, the library from :func:`_ready`.

    Parameters
    ----------
    target_context : BaseContext
        numba's CPU target context.
    libdata, fndesc, env, signature, objectmode, lifted, typeann, reload_init, referenced_envs
        The entry's payload (numba's ``CompileResult._reduce``).

    Returns
    -------
    CompileResult
        As numba's loader returns it.
    """
    codegen = target_context.codegen()
    make = _library(target_context, libdata)
    if make is None:  # numba's loader: its runtime and the hash secrets ready, as numba's own cache has them
        from numba.core.runtime import rtsys

        import numba.cpython.hashing  # noqa: F401 - installs the hash secrets' symbols

        rtsys.initialize(target_context)
        return compiler.CompileResult._rebuild(target_context, libdata, fndesc, env, signature, objectmode, lifted,
                                               typeann, reload_init, referenced_envs)
    for fn in reload_init or ():  # numba runs them before it loads the library
        fn()
    library = make()
    cres = compiler.CompileResult(
        target_context=target_context, typing_context=target_context.typing_context, library=library,
        environment=env, entry_point=target_context.get_executable(library, fndesc, env), fndesc=fndesc,
        type_annotation=typeann, signature=signature, objectmode=objectmode, lifted=lifted, typing_error=None,
        call_helper=None, metadata=None, reload_init=reload_init, referenced_envs=referenced_envs)
    _set_envs(codegen, referenced_envs)
    return cres


def _set_envs(codegen, envs) -> None:
    """numba's ``codegen.set_env`` for each environment, LLVM's lock taken once for all of them.

    An entry names the environments of all the numba functions linked into
    it (a hundred or more for the right-hand side); numba looks each one's
    address up by its own call into LLVM, and every such call takes and
    releases llvmlite's lock, whose callbacks broadcast numba's
    ``numba:llvm_lock`` events (timed during a compilation or load). Here
    the lookups run inside one hold of the lock; where this llvmlite's
    binding does not have the expected shape, numba's own ``set_env`` does
    them.
    """
    try:
        lookup = ll.ffi.lib.LLVMPY_GetGlobalValueAddress._cfn
        lock, engine = ll.ffi.lib._lock, codegen._engine._ee
    except AttributeError:
        for env in envs:
            codegen.set_env(env.env_name, env)
        return
    with lock:
        for env in envs:
            address = lookup(engine, env.env_name.encode("ascii"))
            (ctypes.c_void_p * 1).from_address(address)[0] = id(env)


def _rebuild_env(modname, consts, env_name):
    """numba's ``environment._rebuild_env`` without importing ``modname`` where it is not imported yet."""
    env = environment.lookup_environment(env_name)
    if env is not None:
        return env
    module = sys.modules.get(modname)
    env = environment.Environment(module.__dict__ if module is not None else {"__name__": modname})
    env.consts[:] = consts
    env.env_name = env_name
    environment.Environment._memo[env_name] = env
    return env


class _EntryUnpickler(pickle.Unpickler):
    """numba's cache payload, its environments rebuilt by :func:`_rebuild_env`."""

    def find_class(self, module, name):
        if module == "numba.core.environment" and name == "_rebuild_env":
            return _rebuild_env
        return super().find_class(module, name)


def load_entry(cache_file, key):
    """The payload of ``key`` in a numba index-and-data file (``IndexDataCacheFile.load``), its environments lazy.

    Parameters
    ----------
    cache_file : IndexDataCacheFile
        numba's index and data files of one kernel.
    key : tuple
        The index key (signature, codegen key, code hashes).

    Returns
    -------
    tuple or None
        The payload for :func:`rebuild`, None where the index has no such
        entry or its data file is gone.
    """
    data_name = cache_file._load_index().get(key)
    if data_name is None:
        return None
    try:
        with open(cache_file._data_path(data_name), "rb") as f:
            data = f.read()
    except OSError:  # removed while the index still names it (numba's loader: a miss)
        return None
    return _EntryUnpickler(io.BytesIO(data)).load()
