"""Alternating timing rounds: the house rule "ratios from alternating repeats (min of >= 3)".

A comparison runs in rounds: in each round every configuration of every tool
runs once (flexmb's first, then each peer's), so that a slow spell of the
shared machine falls on all tools alike instead of on one tool's block of
back-to-back repeats. A configuration's time is then the *minimum* over the
rounds (the run least disturbed by other jobs); the times of all rounds are
kept in ``wall_rounds``.

Only the standard library here: the peer scripts import this module in the
peers' venv, ``compare.py`` in the project's.

The peer side of the protocol with ``compare.py`` (:func:`drive`, option
``--rounds-from-stdin`` of the peer scripts): the peer prints
``{"ready": true}`` once imported, then for every line ``round`` read from
stdin runs each of its configurations once, prints one JSON row per run and
``{"round_end": r}``; end of input ends it. Model setup that a peer does once
per model (PyDy's derivation) happens in the first round that needs it.
"""

from __future__ import annotations

import os
import sys

#: the fields that name a configuration (the integrator without its parenthesised detail, so that
#: flexmb's "auto" and its "auto (Radau)" or a peer's failure row and its finished row match)
KEY_FIELDS = ("tool", "scene", "variant", "n_segments", "rtol", "h", "newton_rtol", "atol")


def config_key(row: dict) -> tuple:
    """The configuration a row belongs to."""
    integrator = str(row.get("integrator") or "").split(" (")[0]
    return tuple(row.get(k) for k in KEY_FIELDS) + (integrator,)


def finished(row: dict) -> bool:
    """Whether a row is a timed run that finished (not failed, skipped or timed out)."""
    return row.get("status", "finished") == "finished" and row.get("wall_s") is not None


def merge_rounds(rounds, stat=min) -> list:
    """One row per configuration from the rows of several rounds.

    Parameters
    ----------
    rounds : iterable of list of dict
        The rows of each round, one row per run (``wall_s`` and ``setup_s``
        of that run).
    stat : callable
        Applied to the list of a configuration's times: ``min`` (the house
        rule for ratios) or ``statistics.median``.

    Returns
    -------
    list of dict
        In the order of first appearance. A configuration that finished in
        every round it ran gets ``wall_s = stat(walls)``, ``setup_s =
        stat(setups)`` (where every round has one) and ``wall_rounds`` (the
        walls in round order); its other fields (error, counters, output)
        are those of its first run. A configuration that failed in any round
        is that failure row, unchanged. Rows with ``cpu_s`` (the run's CPU
        time) get ``cpu_s = stat(cpus)`` and ``cpu_rounds`` the same way.
    """
    groups: dict = {}
    for rows in rounds:
        for row in rows:
            groups.setdefault(config_key(row), []).append(row)
    out = []
    for runs in groups.values():
        bad = [r for r in runs if not finished(r)]
        if bad:
            out.append(dict(bad[0]))
            continue
        merged = dict(runs[0])
        walls = [r["wall_s"] for r in runs]
        setups = [r.get("setup_s") for r in runs]
        merged["wall_s"] = stat(walls)
        if all(s is not None for s in setups):
            merged["setup_s"] = stat(setups)
        merged["wall_rounds"] = walls
        cpus = [r.get("cpu_s") for r in runs]
        if all(c is not None for c in cpus):
            merged["cpu_s"] = stat(cpus)
            merged["cpu_rounds"] = cpus
        out.append(merged)
    return out


def blas_threads() -> str | None:
    """OPENBLAS_NUM_THREADS as this process sees it (None when unset)."""
    return os.environ.get("OPENBLAS_NUM_THREADS")


def drive(run_round, repeat: int, from_stdin: bool, emit) -> None:
    """Run a peer's rounds and print its rows.

    Parameters
    ----------
    run_round : callable
        ``run_round(r)`` runs every configuration once (round ``r``, from 0)
        and returns the rows of these runs.
    repeat : int
        Number of rounds when run alone: the rows printed at the end are
        merged with :func:`merge_rounds` (min).
    from_stdin : bool
        Driven by ``compare.py``: wait for a ``round`` line before each
        round and print the rows of each run (``compare.py`` merges them).
    emit : callable
        Prints one JSON row.
    """
    if from_stdin:
        emit({"ready": True})
        r = 0
        for line in sys.stdin:
            if line.strip() != "round":
                break
            for row in run_round(r):
                emit(row)
            emit({"round_end": r})
            r += 1
        return
    for row in merge_rounds([run_round(r) for r in range(repeat)]):
        emit(row)
