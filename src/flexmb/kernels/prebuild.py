"""Build the shipped machine code (:mod:`flexmb.kernels.prebuilt`) from a source checkout.

    OPENBLAS_NUM_THREADS=1 python -m flexmb.kernels.prebuild            # wiper, pendulum, tutorials, tests
    OPENBLAS_NUM_THREADS=1 python -m flexmb.kernels.prebuild --workloads wiper pendulum
    python -m flexmb.kernels.prebuild --check     # CI: fails while a shipped folder is stale

Runs the workloads, each as a new process, with an empty ``NUMBA_CACHE_DIR``
and numba generating code for the baseline CPU (``NUMBA_CPU_NAME``,
``NUMBA_CPU_FEATURES`` empty: the baseline's own features, no SVML), then
copies the kernels' index and data files it filled into
``_prebuilt/<interpreter>-<machine>/`` beside the kernels, with a manifest
(the sources' stamp, numba's and llvmlite's versions, the baseline and its
features, numba's codegen key of the entries). The folder is replaced whole,
and only when every entry carries the sources' stamp and the baseline's key.

After an edit of the kernels the shipped folder is stale (flexmb then
ignores it and compiles, saying why); the folder is rebuilt and committed
as a session's last step, once the kernels stop changing (CONTRIBUTING.md).
``--check`` (a step of ``.ci/run``, :func:`check`) fails, naming this
command, while a shipped folder is stale. The build takes the CPU of
compiling everything the workloads need, plus the test suite's run.

Workloads: ``wiper`` (``flexmb run wiper``, the main job), ``pendulum`` (the
README's "A model in a few lines"), ``tutorials`` (``tutorials/[0-9]*.py``),
``tests`` (the README's test command, ``python -m pytest``: every signature
the suite compiles). A tutorial's or the tests' failure is reported, not
fatal (a tutorial that needs an extra not installed has compiled its kernels
before it stops); the main job's or the pendulum's stops the build.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import pickle
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time

from .cache import KERNELS, sources_stamp
from .prebuilt import BASELINES, folder

#: the checkout this flexmb is installed from (an editable install): README.md, tutorials/, tests/
CHECKOUT = os.path.dirname(os.path.dirname(os.path.dirname(KERNELS)))

WORKLOADS = ("wiper", "pendulum", "tutorials", "tests")


def _pendulum(work: str) -> list[str]:
    with open(os.path.join(CHECKOUT, "README.md"), encoding="utf-8") as f:
        section = f.read().split("## A model in a few lines", 1)[1]
    script = os.path.join(work, "pendulum.py")
    with open(script, "w", encoding="utf-8") as f:
        f.write(re.search(r"```python\n(.*?)```", section, re.S).group(1))
    return [sys.executable, script]


def commands(workload: str, work: str) -> list[list[str]]:
    """The processes a workload runs (each a command line).

    Parameters
    ----------
    workload : str
        One of :data:`WORKLOADS`.
    work : str
        A scratch folder for their outputs.

    Returns
    -------
    list of list of str
        Command lines, run in ``work``.
    """
    if workload == "wiper":
        return [[sys.executable, "-m", "flexmb", "run", "wiper", "--out", os.path.join(work, "wiper"), "--quiet",
                 "--overwrite"]]
    if workload == "pendulum":
        return [_pendulum(work)]
    if workload == "tutorials":
        return [[sys.executable, path] for path in sorted(glob.glob(os.path.join(CHECKOUT, "tutorials", "[0-9]*.py")))]
    if workload == "tests":
        return [[sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", os.path.join(CHECKOUT, "tests")]]
    raise SystemExit(f"unknown workload {workload!r}; the workloads: {', '.join(WORKLOADS)}")


def _environment(cache: str, cpu: str) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, NUMBA_CPU_NAME=cpu, NUMBA_CPU_FEATURES="",
               NUMBA_DISABLE_INTEL_SVML="1", FLEXMB_PREBUILT="0", MPLBACKEND="Agg")
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    return env


def collect(cache_folder: str, out: str, stamp: str, cpu: str, plugin_folders=()) -> dict:
    """Copy the kernels' entries of a filled cache folder into ``out`` and write its manifest.

    Parameters
    ----------
    cache_folder : str
        The folder numba saved the kernels' entries in (``NUMBA_CACHE_DIR``'s
        sub-folder for the kernels' sources): every index there must carry
        ``stamp``.
    out : str
        A new, empty folder.
    stamp : str
        The sources' stamp every index must carry.
    cpu : str
        The baseline the entries were built for.
    plugin_folders : sequence of str
        Other sub-folders of the same cache (plugins' sources): only their
        indexes saved by flexmb's kernel cache (stamped with ``stamp``, as
        the friction plugin's kernel) are shipped; numba's own entries of
        other functions are left out.

    Returns
    -------
    dict
        The manifest written.
    """
    import llvmlite
    import numba

    magic, kernels = set(), []
    indexes = [(index, True) for index in sorted(glob.glob(os.path.join(cache_folder, "*.nbi")))]
    indexes += [(index, False) for folder in plugin_folders for index in sorted(glob.glob(os.path.join(folder, "*.nbi")))]
    for index, required in indexes:
        with open(index, "rb") as f:
            version = pickle.load(f)
            entry_stamp, overloads = pickle.loads(f.read())
        if version != numba.__version__ or entry_stamp != stamp:
            if not required:
                continue
            raise SystemExit(f"{index}: built by numba {version} from other sources; the build is not shipped")
        magic |= {key[1] for key in overloads}
        for name in [os.path.basename(index), *overloads.values()]:
            if name in kernels:
                raise SystemExit(f"{index}: two sources' kernels would share the shipped file {name}")
            shutil.copy(os.path.join(os.path.dirname(index), name), os.path.join(out, name))
            kernels.append(name)
    if len(magic) != 1 or next(iter(magic))[1] != cpu:
        raise SystemExit(f"the entries carry the codegen keys {sorted(magic)}, not one for {cpu}")
    manifest = {"stamp": stamp, "numba": numba.__version__, "llvmlite": llvmlite.__version__, "cpu": cpu,
                "features": BASELINES[cpu], "magic_tuple": list(next(iter(magic))), "kernels": sorted(kernels),
                "built": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    with open(os.path.join(out, "manifest.json"), "w", encoding="utf-8") as f:
        json.dump(manifest, f, indent=1)
    return manifest


def build(workloads, cpu: str = "x86-64-v3", target: str | None = None) -> dict:
    """Run the workloads on an empty cache for ``cpu`` and replace the shipped folder with what they compiled.

    Parameters
    ----------
    workloads : sequence of str
        Names from :data:`WORKLOADS`.
    cpu : str
        The baseline (a key of :data:`flexmb.kernels.prebuilt.BASELINES`).
    target : str, optional
        The folder to write (this interpreter's shipped folder by default).

    Returns
    -------
    dict
        The manifest written.
    """
    from numba.core.caching import UserProvidedCacheLocator

    target = target or folder()
    stamp = sources_stamp()
    with tempfile.TemporaryDirectory(prefix="flexmb-prebuild-") as work:
        cache = os.path.join(work, "cache")
        env = _environment(cache, cpu)
        for workload in workloads:
            for argv in commands(workload, work):
                t0, r0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
                # the README's test command runs in the checkout (tests read tutorials/ relative to it)
                proc = subprocess.run(argv, env=env, cwd=CHECKOUT if workload == "tests" else work,
                                      capture_output=True, text=True)
                r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                seconds = r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime
                lines = proc.stdout.strip().splitlines() or [""]
                failed = [ln for ln in lines if ln.startswith(("FAILED ", "ERROR "))]
                print(f"{workload}: {' '.join(os.path.basename(a) for a in argv[1:3])}: exit {proc.returncode}, "
                      f"{seconds:.1f} s CPU, {time.perf_counter() - t0:.0f} s wall; {lines[-1]}",
                      *failed, sep="\n", file=sys.stderr, flush=True)
                if proc.returncode and workload in ("wiper", "pendulum"):
                    raise SystemExit(f"{argv} failed:\n{proc.stderr[-3000:]}")
        sources_stamp.cache_clear()
        if sources_stamp() != stamp:
            raise SystemExit("the kernels' sources changed during the build: run it again")
        filled = os.path.join(cache, UserProvidedCacheLocator.get_suitable_cache_subpath(
            os.path.join(KERNELS, "tree.py")))
        others = [path for path in glob.glob(os.path.join(cache, "*")) if path != filled and os.path.isdir(path)]
        os.makedirs(os.path.dirname(target), exist_ok=True)
        new = tempfile.mkdtemp(prefix=".new-", dir=os.path.dirname(target))
        try:
            manifest = collect(filled, new, stamp, cpu, others)
            os.chmod(new, 0o755)
            if os.path.exists(target):
                shutil.rmtree(target)
            os.replace(new, target)
        finally:
            shutil.rmtree(new, ignore_errors=True)
    return manifest


#: the command that rebuilds the shipped folder (said by :func:`check`)
REBUILD = "OPENBLAS_NUM_THREADS=1 python -m flexmb.kernels.prebuild"


def check(root: str | None = None) -> list[str]:
    """What makes the shipped folders stale: one line per problem, empty where all are fresh or none is shipped.

    Every folder of ``root`` (one per interpreter and machine) must hold
    exactly the files its manifest lists, built from the kernels' sources
    as they are (:func:`flexmb.kernels.cache.sources_stamp`); this
    interpreter's folder must also be for the numba and llvmlite installed.

    Parameters
    ----------
    root : str, optional
        The folder of all shipped builds (:data:`flexmb.kernels.prebuilt.ROOT`
        by default).

    Returns
    -------
    list of str
        Each names the folder and what does not fit.
    """
    import llvmlite
    import numba

    from . import prebuilt

    root = root or prebuilt.ROOT
    problems = []
    for path in sorted(glob.glob(os.path.join(glob.escape(root), "*"))):
        if not os.path.isdir(path) or os.path.basename(path).startswith("."):
            continue
        manifest = prebuilt.read_manifest(path)
        if manifest is None:
            problems.append(f"{path}: no readable manifest.json")
            continue
        if manifest.get("stamp") != sources_stamp():
            problems.append(f"{path}: built from other kernel sources than these (built {manifest.get('built')}; "
                            f"a kernel was edited since)")
        if set(os.listdir(path)) - {"manifest.json"} != set(manifest.get("kernels", [])):
            problems.append(f"{path}: holds other files than its manifest lists")
        if os.path.basename(path) == os.path.basename(folder()):
            for name, have in (("numba", numba.__version__), ("llvmlite", llvmlite.__version__)):
                if manifest.get(name) != have:
                    problems.append(f"{path}: built for {name} {manifest.get(name)}, this environment has {have}")
    return problems


def _check() -> None:
    problems = check()
    if problems:
        raise SystemExit("the shipped machine code is stale:\n  " + "\n  ".join(problems)
                         + f"\nrebuild it and commit the folder: {REBUILD} (CONTRIBUTING.md)")
    print("the shipped machine code is fresh (or none is shipped)")


def main(argv=None) -> None:
    """The command line: ``python -m flexmb.kernels.prebuild [--workloads ...] [--cpu ...] [--check]``."""
    p = argparse.ArgumentParser(prog="python -m flexmb.kernels.prebuild", description=__doc__.split("\n", 1)[0])
    p.add_argument("--workloads", nargs="+", choices=WORKLOADS, default=list(WORKLOADS))
    p.add_argument("--cpu", choices=sorted(BASELINES), default="x86-64-v3")
    p.add_argument("--target", help="the folder to write (default: this interpreter's shipped folder)")
    p.add_argument("--check", action="store_true", help="build nothing: fail, saying why, where a shipped folder is "
                                                        "stale (a step of .ci/run)")
    args = p.parse_args(argv)
    if args.check:
        return _check()
    manifest = build(args.workloads, args.cpu, args.target)
    size = sum(os.path.getsize(os.path.join(args.target or folder(), n)) for n in manifest["kernels"])
    print(f"{len(manifest['kernels'])} files, {size / 1e6:.1f} MB, for numba {manifest['numba']} on "
          f"{manifest['cpu']}: {args.target or folder()}")


if __name__ == "__main__":
    main()
