"""Where the kernels' machine code is cached, and what happens when it cannot be.

Every kernel is declared with :func:`njit`, numba's decorator with a cache
that never stops flexmb from running:

* **Shipped.** Machine code shipped with the sources, precompiled for a
  portable CPU (:mod:`flexmb.kernels.prebuilt`), is read first where it
  is fresh and this CPU can run it; it is never written. What it does not
  serve goes through the cache below.
* **Where.** The first of: ``NUMBA_CACHE_DIR`` if it is writable; the
  ``__pycache__`` beside these sources if it is writable (an editable or
  per-user install); a warm ``__pycache__`` or ``NUMBA_CACHE_DIR`` that can
  only be read (a root-owned install warmed by its owner, a read-only
  image), used read-only; numba's user-wide cache (``~/.cache/numba``); a
  per-user folder in the system's temporary directory (no writable home: a
  service account, a container); else no cache at all: the kernels compile
  in memory, each run, with a one-line notice.
* **Freshness.** A kernel's entry is stamped with a hash of *all* the
  kernels' sources, not only its own file: a kernel inlines or calls
  kernels of other files, and numba's own stamp would keep a caller's stale
  machine code after a callee changed.
* **Loading.** An entry's machine code is made ready to run without
  parsing its LLVM bitcode, which only a later compilation linking against
  the kernel needs (:mod:`flexmb.kernels.lazy_bitcode`).
* **Damage.** An index or data file that cannot be read back (truncated,
  empty, random: what a crash or a full disk can leave) is a cache miss:
  the kernel compiles and its entry is rewritten (or, in a read-only cache,
  left alone). A cache that cannot be written is never an error.
"""

from __future__ import annotations

import functools
import glob
import hashlib
import os
import sys
import tempfile

import numba
from numba.core.caching import (
    CompileResultCacheImpl,
    FunctionCache,
    InTreeCacheLocator,
    UserProvidedCacheLocator,
    UserWideCacheLocator,
    _CacheLocator,
    _SourceFileBackedLocatorMixin,
)

from . import interpreted, lazy_bitcode, prebuilt

__all__ = ["njit", "cache_locations", "sources_stamp"]

#: the kernels' folder: the sources whose hash stamps every entry
KERNELS = os.path.dirname(os.path.abspath(__file__))

#: the files of the kernels' folder that hold no kernel (not stamped)
NOT_KERNELS = ("cache.py", "compiling.py", "interpreted.py", "lazy_bitcode.py", "prebuilt.py", "prebuild.py")

#: notices already given in this process (each at most once)
_told: set[str] = set()


def _notice(key: str, text: str) -> None:
    if key not in _told:
        _told.add(key)
        print(f"flexmb: {text}", file=sys.stderr)


@functools.lru_cache(maxsize=None)
def sources_stamp(folder: str = KERNELS) -> str:
    """A hash of every kernel source file in ``folder`` (names and contents), computed once per process."""
    h = hashlib.sha256()
    for path in sorted(glob.glob(os.path.join(glob.escape(folder), "*.py"))):
        if os.path.basename(path) in NOT_KERNELS:
            continue
        h.update(os.path.basename(path).encode())
        with open(path, "rb") as f:
            h.update(f.read())
    return h.hexdigest()


class _WholeSourceStamp:
    """Stamp entries with all the kernels' sources (a callee's change makes its callers stale too)."""

    def get_source_stamp(self):
        return sources_stamp()


def _has_entry(folder: str, py_func, py_file: str) -> bool:
    """Whether ``folder`` holds a cache index of this kernel (any Python version's)."""
    name = f"{os.path.splitext(os.path.basename(py_file))[0]}.{py_func.__qualname__}-{py_func.__code__.co_firstlineno}"
    return bool(glob.glob(os.path.join(glob.escape(folder), glob.escape(name) + ".py*.nbi")))


class _UserProvided(_WholeSourceStamp, UserProvidedCacheLocator):
    """``NUMBA_CACHE_DIR``, if writable."""


class _InTree(_WholeSourceStamp, InTreeCacheLocator):
    """The ``__pycache__`` beside the sources, if writable."""


class _ReadOnly(_WholeSourceStamp, _SourceFileBackedLocatorMixin, _CacheLocator):
    """A warm cache that can only be read: ``NUMBA_CACHE_DIR`` or the ``__pycache__`` beside the sources.

    Chosen for a kernel only where it holds that kernel's index; a new
    entry cannot be written there (:class:`KernelCache` skips the save).
    """

    def __init__(self, py_func, py_file, folder):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = folder

    def get_cache_path(self):
        return self._cache_path

    def ensure_cache_path(self):
        if not os.access(self._cache_path, os.R_OK | os.X_OK):
            raise OSError(f"cannot read {self._cache_path}")

    @classmethod
    def from_function(cls, py_func, py_file):
        if not os.path.exists(py_file):
            return None
        folders = [os.path.join(os.path.dirname(py_file), "__pycache__")]
        if numba.config.CACHE_DIR:
            folders.insert(0, os.path.join(numba.config.CACHE_DIR,
                                           UserProvidedCacheLocator.get_suitable_cache_subpath(py_file)))
        for folder in folders:
            if os.access(folder, os.R_OK | os.X_OK) and _has_entry(folder, py_func, py_file):
                return cls(py_func, py_file, folder)
        return None


class _UserWide(_WholeSourceStamp, UserWideCacheLocator):
    """numba's user-wide cache (``~/.cache/numba``), if writable."""


class _PerUserTemp(_WholeSourceStamp, _SourceFileBackedLocatorMixin, _CacheLocator):
    """``<tmp>/flexmb-numba-<uid>``: no writable home (a service account, a container)."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        uid = os.getuid() if hasattr(os, "getuid") else os.getlogin()
        self._cache_path = os.path.join(tempfile.gettempdir(), f"flexmb-numba-{uid}",
                                        self.get_suitable_cache_subpath(py_file))

    def get_cache_path(self):
        return self._cache_path

    def ensure_cache_path(self):
        super().ensure_cache_path()
        top = os.path.dirname(self._cache_path)
        st = os.stat(top)
        if hasattr(os, "getuid") and (st.st_uid != os.getuid() or st.st_mode & 0o022):
            # another user's folder (or one others can write): never load machine code from it
            raise OSError(f"{top} is not this user's own folder")

    @classmethod
    def from_function(cls, py_func, py_file):
        if not os.path.exists(py_file):
            return None
        self = cls(py_func, py_file)
        try:
            os.makedirs(os.path.dirname(self._cache_path), mode=0o700, exist_ok=True)
            self.ensure_cache_path()
        except OSError:
            return None
        return self

    def tell(self):
        """Say, once, where kernels compiled in this process are cached (at the first save: a load says nothing)."""
        _notice("temp", f"no writable cache folder for the compiled kernels (NUMBA_CACHE_DIR, beside the sources, "
                        f"~/.cache): caching them in {os.path.dirname(self._cache_path)}")


class _InMemory(_WholeSourceStamp, _SourceFileBackedLocatorMixin, _CacheLocator):
    """No cache anywhere: compile in memory (a miss on every load, no save)."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno

    def get_cache_path(self):
        return os.path.join(tempfile.gettempdir(), "flexmb-numba-none")  # never created, never read

    def ensure_cache_path(self):
        raise OSError("no cache")

    @classmethod
    def from_function(cls, py_func, py_file):
        return cls(py_func, py_file)

    def tell(self):
        """Say, once, that compiled kernels are not kept (at the first compilation: shipped code says nothing)."""
        _notice("memory", "no folder can hold the compiled kernels' cache: compiling them in memory, in every run "
                          "(set NUMBA_CACHE_DIR to a writable folder to keep them)")


class _KernelCacheImpl(CompileResultCacheImpl):
    _locator_classes = [_UserProvided, _InTree, _ReadOnly, _UserWide, _PerUserTemp, _InMemory]

    def rebuild(self, target_context, payload):
        """An entry's compile result, its bitcode parsed only if a compilation links it (:mod:`.lazy_bitcode`)."""
        return lazy_bitcode.rebuild(target_context, *payload)


def _ready_to_load(target_context) -> None:
    """Make ``target_context`` able to link cached machine code, without loading numba's compiler registries.

    numba's own cache calls ``target_context.refresh()`` before every load:
    the first call in a process imports and installs all of numba's typing
    and lowering registries (numba.np, numba.cpython, typed containers,
    jitclass, ...), which only a *compilation* uses, and which cost more than
    loading all the kernels of a run (``benchmarks/startup.py --breakdown``).
    Machine code read from the cache needs only the symbols it may call:
    numba's C helpers and the C math functions (installed when the context
    is created) and the runtime's C functions
    (:func:`.lazy_bitcode.runtime_symbols`); an entry that also uses the
    runtime's compiled functions or the hash secrets gets them at its load
    (:func:`.lazy_bitcode.rebuild`). A compilation in the same process (a
    miss) still refreshes the context fully, as numba's compiler does before
    every compilation.
    """
    lazy_bitcode.runtime_symbols()


class _Baseline:
    """Stands for a code generator in numba's index key: the shipped entries' ``magic_tuple``."""

    def __init__(self, magic):
        self._magic = magic

    def magic_tuple(self):
        return self._magic


class KernelCache(FunctionCache):
    """numba's per-function cache, with the locators above and damage taken as a miss.

    A load tries the shipped entries first (:mod:`flexmb.kernels.prebuilt`,
    keyed by the baseline CPU's codegen key instead of this process's), then
    the locator's folder; a save goes to the locator's folder only. The
    locator is chosen at the cache's first use (:meth:`__getattr__`).

    Parameters
    ----------
    py_func : function
        The kernel's Python function.
    full_refresh : bool
        Refresh numba's target context fully before a load, as numba does
        (needed for kernels whose machine code calls into numba's threading
        layer: ``parallel=True``); otherwise :func:`_ready_to_load`.
    """

    _impl_class = _KernelCacheImpl

    def __init__(self, py_func, full_refresh: bool = False):
        self._lazy_py_func = py_func  # located at the first use: most kernels are never loaded in a run
        self._full_refresh = full_refresh

    def __getattr__(self, name):
        """numba's attributes (``_impl``, ``_cache_file``, ``_enabled``, ...): the cache located at the first read.

        numba's ``Cache.__init__`` chooses the locator and checks its folder
        by writing a temporary file there: done per kernel at the first load
        or save, not for every kernel at import.
        """
        py_func = self.__dict__.pop("_lazy_py_func", None)
        if py_func is None or name.startswith("__"):
            raise AttributeError(name)
        super().__init__(py_func)
        return getattr(self, name)

    def load_overload(self, sig, target_context):
        shipped = self._load_shipped(sig, target_context)
        if shipped is not None:
            return shipped
        if isinstance(self._impl.locator, _InMemory):
            return None
        try:
            if self._full_refresh:
                return super().load_overload(sig, target_context)
            _ready_to_load(target_context)
            with self._guard_against_spurious_io_errors():
                return self._load_overload(sig, target_context)
        except Exception:  # noqa: BLE001 - any unreadable entry (EOFError, UnpicklingError, ...) is a miss
            self._discard()
            return None

    def _load_overload(self, sig, target_context):
        """numba's load from the locator's folder, the entry read by :func:`.lazy_bitcode.load_entry`."""
        if not self._enabled:
            return None
        data = lazy_bitcode.load_entry(self._cache_file, self._index_key(sig, target_context.codegen()))
        return None if data is None else self._impl.rebuild(target_context, data)

    def _load_shipped(self, sig, target_context):
        """This signature's machine code from the shipped entries (:mod:`flexmb.kernels.prebuilt`), or None."""
        if not self._enabled:
            return None
        try:
            codegen = target_context.codegen()
            magic = prebuilt.magic_tuple(codegen.magic_tuple()[0], sources_stamp())
            entry = magic and prebuilt.entry_file(self._impl.filename_base, sources_stamp())
            if not entry:
                return None
            if self._full_refresh:
                target_context.refresh()
            else:
                _ready_to_load(target_context)
            data = lazy_bitcode.load_entry(entry, self._index_key(sig, _Baseline(magic)))
            return None if data is None else self._impl.rebuild(target_context, data)
        except Exception:  # noqa: BLE001 - a shipped entry that cannot be read is a miss, never an error
            return None

    def save_overload(self, sig, data):
        if isinstance(self._impl.locator, (_InMemory, _PerUserTemp)):
            self._impl.locator.tell()
        if isinstance(self._impl.locator, (_InMemory, _ReadOnly)):
            return
        try:
            super().save_overload(sig, data)
        except Exception:  # noqa: BLE001 - a damaged index, a full disk, a folder gone read-only
            self._discard()
            try:
                super().save_overload(sig, data)
            except Exception:  # noqa: BLE001 - the machine code stays in memory for this run
                pass

    def _discard(self):
        """Rewrite this kernel's damaged index empty (its data files are then overwritten as new)."""
        if isinstance(self._impl.locator, (_InMemory, _ReadOnly)):
            return
        try:
            self._cache_file.flush()
        except Exception:  # noqa: BLE001 - a folder that cannot be written: the entry stays a miss
            pass


def njit(*args, cache: bool = False, **options):
    """The kernels' decorator: numba's ``njit``, with :class:`KernelCache` for ``cache=True``.

    Parameters
    ----------
    *args
        numba's positional arguments (or the function itself, for a bare
        ``@njit``).
    cache : bool
        Cache the machine code as the module docstring says.
    **options
        numba's ``njit`` options (``inline``, ``fastmath``, ...).

    Returns
    -------
    Dispatcher or callable
        The compiled function, or the decorator that makes it. With
        ``NUMBA_DISABLE_JIT=1`` the Python function, ready to run as Python
        (:mod:`flexmb.kernels.interpreted`).
    """
    if args and callable(args[0]):  # bare @njit
        return njit(cache=cache, **options)(args[0])

    def decorate(func):
        if interpreted.disabled():  # NUMBA_DISABLE_JIT=1: numba returns the Python function
            return interpreted.kernel(numba.njit(*args, **options)(func))
        dispatcher = numba.njit(*args, **options)(func)
        if cache:
            dispatcher._cache = KernelCache(dispatcher.py_func, full_refresh=bool(options.get("parallel")))
        return dispatcher

    return decorate


def cache_locations() -> dict[str, str]:
    """Where each cached kernel imported so far is read from and saved to.

    Returns
    -------
    dict
        ``"module.kernel"`` (e.g. ``"tree.tree_kinematics"``) -> its cache
        folder, or ``"memory"`` where no folder can hold it.
    """
    out = {}
    for modname, mod in sorted(sys.modules.items()):
        if not modname.startswith(__name__.rsplit(".", 1)[0] + ".") or mod is None:
            continue
        for name, obj in vars(mod).items():
            kernel_cache = getattr(obj, "_cache", None)
            if isinstance(kernel_cache, KernelCache) and getattr(obj, "__module__", "") == modname:
                loc = kernel_cache._impl.locator
                out[f"{modname.rsplit('.', 1)[-1]}.{name}"] = (
                    "memory" if isinstance(loc, _InMemory) else loc.get_cache_path())
    return out
