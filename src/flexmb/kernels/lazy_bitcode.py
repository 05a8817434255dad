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
"""

from __future__ import annotations

import struct

from llvmlite import binding as ll
from numba.core import compiler
from numba.core.codegen import JITCodeLibrary

__all__ = ["LazyLinkLibrary", "rebuild", "elf_defined_symbols"]

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
    if obj[:4] != b"\x7fELF" or obj[4:6] != b"\x02\x01":  # 64-bit, little-endian
        return None
    shoff, = struct.unpack_from("<Q", obj, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", obj, 0x3A)
    sections = [struct.unpack_from("<IIQQQQIIQQ", obj, shoff + i * shentsize) for i in range(shnum)]
    names = set()
    for _, sh_type, _, _, offset, size, link, _, _, _ in sections:
        if sh_type != 2:  # SHT_SYMTAB
            continue
        strings = sections[link][4]
        for st_name, st_info, _, st_shndx, _, _ in struct.iter_unpack("<IBBHQQ", obj[offset:offset + size]):
            if st_shndx == 0 or not st_name or st_info & 0xF in _NO_SYMBOL_TYPES:
                continue
            start = strings + st_name
            names.add(obj[start:obj.index(b"\0", start)].decode())
    return names


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


def _library(codegen, libdata):
    """A cached library made ready to run (its bitcode unparsed), or None where numba's own loader must do it."""
    name, kind, data = libdata
    if kind != "object" or codegen._library_class is not JITCodeLibrary:
        return None
    object_code, bitcode = data
    symbols = elf_defined_symbols(object_code)
    if symbols is None:
        return None
    return lambda: _ready(codegen, name, object_code, bitcode, symbols)


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
    make = _library(codegen, libdata)
    if make is None:
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
    for referenced in referenced_envs:
        codegen.set_env(referenced.env_name, referenced)
    return cres
