"""Output folders that cannot be turned against their owner (issue #33, section 3).

Whoever can write into an output folder (another user of a shared folder, a
link left there by mistake) must not make a run overwrite, create or delete
files elsewhere, nor delete files in the folder that no run wrote, nor lock
the folder for ever. Each test reproduces one probe of the issue; each
failed on main 2f45815.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys
import textwrap
import time

import pytest

import flexmb as fm
from flexmb._files import LOCK_NAME, MANIFEST_NAME, WRITTEN, OutputFolder, atomic_write
from flexmb.cli import main

TUTORIALS = pathlib.Path(__file__).resolve().parents[2] / "tutorials"
PENDULUM = str(TUTORIALS / "01_pendulum.toml")

pytestmark = pytest.mark.skipif(not hasattr(os, "symlink") or os.name != "posix", reason="POSIX links")


def _run(out, t_end=0.1, n_out=5, *extra):
    return main(["run", PENDULUM, "--out", str(out), "--t-end", str(t_end), "--n-out", str(n_out), "--quiet",
                 *extra])


# ----------------------------------------------------------------------------- the lock file


def test_a_lock_linked_to_a_file_is_refused_and_the_file_untouched(tmp_path, capsys):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).symlink_to(victim)
    assert _run(out) == 3
    err = capsys.readouterr().err
    assert f"{out / LOCK_NAME} is a symbolic link" in err and "Traceback" not in err
    assert victim.read_text() == "precious\n"  # main truncated it and wrote the pid
    assert not (out / "summary.json").exists()


def test_a_dangling_lock_link_creates_nothing(tmp_path, capsys):
    target = tmp_path / "elsewhere" / "created"
    target.parent.mkdir()
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).symlink_to(target)
    assert _run(out) == 3
    assert "is a symbolic link" in capsys.readouterr().err
    assert not os.path.lexists(target)  # main created the link's target


def test_a_lock_hard_linked_to_a_file_is_refused(tmp_path, capsys):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    out = tmp_path / "out"
    out.mkdir()
    os.link(victim, out / LOCK_NAME)
    assert _run(out) == 3
    assert "has other names (a hard link)" in capsys.readouterr().err
    assert victim.read_text() == "precious\n"


def test_the_lock_file_is_not_inherited_by_programs_a_run_starts(tmp_path):
    with OutputFolder(tmp_path) as folder:
        assert not os.get_inheritable(folder._lock.fd)
        flags = __import__("fcntl").fcntl(folder._lock.fd, __import__("fcntl").F_GETFD)
        assert flags & __import__("fcntl").FD_CLOEXEC


# ----------------------------------------------------------------------------- stale locks


def test_a_lock_naming_a_live_but_unrelated_process_is_taken_over(tmp_path, capsys):
    # a stale lock whose pid was reused since: the process lives but holds no flock on the file
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        (tmp_path / LOCK_NAME).write_text(f"{sleeper.pid}\n")
        assert _run(tmp_path) == 0  # main refused: "in use by another flexmb run (pid ...)", for ever
    finally:
        sleeper.kill()
        sleeper.wait()
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "finished"
    assert not (tmp_path / LOCK_NAME).exists()


HOLDER = textwrap.dedent("""
    import fcntl, os, sys, time
    fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX)
    os.write(fd, b"%d\\n" % os.getpid())
    open(sys.argv[2], "w").close()
    time.sleep(60)
""")


def test_a_lock_whose_flock_is_held_is_respected(tmp_path, capsys):
    started = tmp_path / "started"
    out = tmp_path / "out"
    out.mkdir()
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(out / LOCK_NAME), str(started)])
    try:
        end = time.monotonic() + 60
        while not started.exists() and time.monotonic() < end:
            time.sleep(0.01)
        assert _run(out) == 3
    finally:
        holder.kill()
        holder.wait()
    assert f"in use by another flexmb run (pid {holder.pid}" in capsys.readouterr().err
    assert _run(out) == 0  # the holder died: its flock went with it


# ----------------------------------------------------------------------------- the manifest


def _first_run(tmp_path):
    out = tmp_path / "out"
    assert _run(out, 0.2, 11) == 0
    return out


def test_a_forged_manifest_removes_nothing_a_run_did_not_write(tmp_path):
    out = _first_run(tmp_path)
    (out / "notes.txt").write_text("mine")
    (out / "data").mkdir()
    (out / "data" / "x.csv").write_text("mine")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "pendulum_0001.vtu").write_text("mine")
    (out / "sub").mkdir()
    (out / "sub" / "link").symlink_to(elsewhere)
    manifest = json.loads((out / MANIFEST_NAME).read_text())
    manifest["files"] += ["notes.txt", "data/x.csv", "sub/link/pendulum_0001.vtu", "../elsewhere/pendulum_0001.vtu"]
    (out / MANIFEST_NAME).write_text(json.dumps(manifest))
    assert _run(out, 0.1, 5) == 0
    assert (out / "notes.txt").read_text() == "mine"  # main removed it
    assert (out / "data" / "x.csv").read_text() == "mine"
    assert (elsewhere / "pendulum_0001.vtu").read_text() == "mine"
    assert len(list((out / "vtk").glob("*.vtu"))) == 5  # the run's own stale files went


def test_a_manifest_linked_from_elsewhere_is_refused(tmp_path, capsys):
    out = _first_run(tmp_path)
    (out / "pendulum_notes.png").write_text("mine, named like a plot")
    forged = tmp_path / "forged.json"
    forged.write_text(json.dumps({"format": 1, "writer": "flexmb", "files": ["pendulum_notes.png"],
                                  "owner": os.path.realpath(PENDULUM)}))
    (out / MANIFEST_NAME).unlink()
    (out / MANIFEST_NAME).symlink_to(forged)
    assert _run(out, 0.1, 5) == 3
    assert f"{out / MANIFEST_NAME} is a symbolic link" in capsys.readouterr().err
    assert (out / "pendulum_notes.png").read_text() == "mine, named like a plot"  # main removed it


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="needs root to give a file away")
def test_another_users_manifest_is_not_trusted(tmp_path):
    out = _first_run(tmp_path)
    (out / "pendulum_notes.png").write_text("mine, named like a plot")
    manifest = json.loads((out / MANIFEST_NAME).read_text())
    manifest["files"].append("pendulum_notes.png")
    (out / MANIFEST_NAME).write_text(json.dumps(manifest))
    os.chown(out / MANIFEST_NAME, 65534, 65534)
    assert _run(out, 0.1, 5) == 0
    assert (out / "pendulum_notes.png").read_text() == "mine, named like a plot"


def test_every_file_a_run_writes_is_named_as_the_writers_name_them(tmp_path, capsys):
    scene = tmp_path / "runs.toml"
    scene.write_text(pathlib.Path(PENDULUM).read_text()
                     + '\n[runs.light]\n"bodies.bar.mass" = 0.5\n[runs."two words"]\n"bodies.bar.mass" = 2.0\n')
    for out, argv in ((tmp_path / "a", [PENDULUM]), (tmp_path / "b", [str(scene)]), (tmp_path / "c", ["fourbar"])):
        assert main(["run", *argv, "--out", str(out), "--t-end", "0.1", "--n-out", "3", "--quiet"]) == 0
        files = json.loads((out / MANIFEST_NAME).read_text())["files"]
        assert len(files) > 3 and [f for f in files if not WRITTEN.fullmatch(f)] == [], files


# ----------------------------------------------------------------------------- linked sub-folders


def test_a_linked_vtk_folder_is_refused_and_nothing_written_through_it(tmp_path, capsys):
    out = _first_run(tmp_path)
    other = tmp_path / "other"
    other.mkdir()
    (other / "pendulum_0001.vtu").write_text("another folder's file")
    for p in (out / "vtk").iterdir():
        p.unlink()
    (out / "vtk").rmdir()
    (out / "vtk").symlink_to(other)
    assert _run(out, 0.1, 5) == 3
    err = capsys.readouterr().err
    assert f"{out / 'vtk'} is a symbolic link" in err and "Traceback" not in err
    # main wrote the new series into the other folder and removed one of its files
    assert sorted(p.name for p in other.iterdir()) == ["pendulum_0001.vtu"]
    assert (other / "pendulum_0001.vtu").read_text() == "another folder's file"


def test_a_folder_linked_while_the_run_writes_is_refused_before_the_commit(tmp_path):
    other = tmp_path / "other"
    other.mkdir()
    out = tmp_path / "out"
    with pytest.raises(fm.ExportError, match="is a symbolic link"):
        with OutputFolder(out) as folder:
            atomic_write(folder.stage("vtk/a_0001.vtu"), lambda tmp: pathlib.Path(tmp).write_text("new"))
            (out / "vtk").symlink_to(other)
            folder.commit()
    assert list(other.iterdir()) == []
    assert not (out / ".flexmb-commit").exists() and not list(out.glob(".flexmb-staging-*"))


def test_a_linked_commit_folder_moves_nothing_out_of_its_target(tmp_path):
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "a.npz").write_text("mine")
    (victim / MANIFEST_NAME).write_text(json.dumps({"files": ["a.npz"]}))
    out = tmp_path / "out"
    out.mkdir()
    (out / ".flexmb-commit").symlink_to(victim)
    with pytest.raises(fm.ExportError, match="flexmb-commit is a symbolic link"):
        with OutputFolder(out):
            pass
    assert (victim / "a.npz").read_text() == "mine" and not (out / "a.npz").exists()


def test_a_linked_cases_folder_is_refused_by_a_study(tmp_path, capsys):
    other = tmp_path / "other"
    other.mkdir()
    out = tmp_path / "out"
    out.mkdir()
    (out / "cases").symlink_to(other)
    assert main(["study", PENDULUM, "--vary", "bodies.bar.mass=1,2", "--set", "solver.t_end=0.05", "--serial",
                 "--quiet", "--out", str(out)]) == 3
    assert f"{out / 'cases'} is a symbolic link" in capsys.readouterr().err
    assert list(other.iterdir()) == []
