"""What benchmarks/test_command_compile.py counts and reports (issue 31).

The compiles a run saved (numba index files created or rewritten, data
files created), pytest's counts from its last line, and the table: compile
= cold - warm per venv and round, against the base's of the same round. No
timing is asserted: the times in these rows are made up.
"""

from __future__ import annotations

import json
import os
import sys

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)

import test_command_compile as tcc  # noqa: E402


def test_saved_counts_new_and_rewritten_indexes_and_new_data_files(tmp_path):
    (tmp_path / "a.nbi").write_bytes(b"1")
    (tmp_path / "a.1.nbc").write_bytes(b"1")
    (tmp_path / "other.txt").write_bytes(b"1")
    before = tcc.cache_files(str(tmp_path))
    assert sorted(os.path.basename(k) for k in before) == ["a.1.nbc", "a.nbi"]
    (tmp_path / "a.nbi").write_bytes(b"22")  # rewritten: a new signature of a
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.nbi").write_bytes(b"1")
    (tmp_path / "sub" / "b.1.nbc").write_bytes(b"1")
    assert tcc.saved(before, tcc.cache_files(str(tmp_path))) == {"nbi": 2, "nbc": 1}
    assert tcc.saved(before, before) == {"nbi": 0, "nbc": 0}


def test_pytest_counts_are_read_from_its_last_line():
    line = "3481 passed, 23 skipped, 1 failed, 12 warnings in 1438.62s (0:23:58)"
    assert {w: int(n) for n, w in tcc.COUNTS.findall(line)} == {
        "passed": 3481, "skipped": 23, "failed": 1, "warnings": 12}


def _row(venv, cache, cpu, r=0, tests="all"):
    return {"venv": venv, "commit": venv[:4], "tests": tests, "cache": cache, "round": r, "cpu_s": cpu,
            "wall_s": 10 * cpu, "counts": {"passed": 5, "skipped": 1}, "shared": {"nbi": 2, "nbc": 3},
            "probes": {"nbi": 0, "nbc": 0}, "load_min": 1.0, "load_max": 2.0}


def test_summary_gives_compile_as_cold_less_warm_against_the_base_of_the_round(tmp_path):
    out = tmp_path / "rows.jsonl"
    rows = [_row("base", "cold", 150.0), _row("now", "cold", 305.0), _row("base", "warm", 100.0),
            _row("now", "warm", 300.0), _row("base", "cold", 999.0, r=1)]  # round 1 without its warm run
    out.write_text("".join(json.dumps(r) + "\n" for r in rows))
    lines = tcc.summary(str(out), base="base").splitlines()
    body = [ln.split(" | ") for ln in lines[2:]]
    assert [(b[1], b[6], b[7]) for b in body] == [("base", "+50.0", "1.000"), ("now", "+5.0", "0.100")]
