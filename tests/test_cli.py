"""The ``flexmb`` command: run and info on scene files, errors, interrupted runs.

Most tests call :func:`flexmb.cli.main` in-process; one runs the real
``python -m flexmb`` in a subprocess.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import flexmb as fm
from flexmb.cli import main

STEPPING = sys.modules["flexmb.stepping"]  # the step loop shows the progress bar

TUTORIALS = pathlib.Path(__file__).resolve().parents[1] / "tutorials"
PENDULUM = str(TUTORIALS / "01_pendulum.toml")
FOURBAR = str(TUTORIALS / "02_fourbar.toml")


def test_info_reports_coordinates_constraints_and_freedoms(capsys):
    assert main(["info", FOURBAR]) == 0
    out = capsys.readouterr().out
    assert "crank: rigid_body, mass 0.1 kg" in out
    assert "A: revolute ground -> crank; coordinates A.angle" in out
    assert "C: planar_revolute coupler -> rocker; cut joint closing a loop, 2 constraint rows" in out
    assert "coordinates: n = 3" in out
    assert "rank of psi at the initial state: 2; redundant rows: 0" in out
    assert "degrees of freedom: p = n - rank = 1" in out


def test_info_finds_the_redundant_rows_of_a_spatial_cut(tmp_path, capsys):
    # a spatial revolute closing a planar loop writes 5 rows of rank 2 (3 redundant), as tutorial 02 shows
    text = pathlib.Path(FOURBAR).read_text().replace('type = "planar_revolute"', 'type = "revolute"')
    scene = tmp_path / "spatial.toml"
    scene.write_text(text)
    assert main(["info", str(scene)]) == 0
    out = capsys.readouterr().out
    assert "constraint rows: m = 5" in out
    assert "rank of psi at the initial state: 2; redundant rows: 3" in out
    assert "degrees of freedom: p = n - rank = 1" in out


def test_info_gives_the_stiffness_hint(capsys):
    assert main(["info", str(TUTORIALS / "04_wiper.toml")]) == 0
    out = capsys.readouterr().out
    assert "degrees of freedom: p = n - rank = 24 (drivers prescribe 1)" in out  # 9 + 2 * 6 * 2 - 9
    assert "'auto' picks CVODE_BDF" in out


def test_run_writes_results_summary_plot_and_vtk(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", PENDULUM, "--out", str(out), "--t-end", "0.2", "--n-out", "21", "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "finished" and summary["t_end"] == pytest.approx(0.2)
    assert summary == json.loads(capsys.readouterr().out.split("\nwrote ")[0])
    res = fm.Result.load(out / "pendulum.npz")
    ref = fm.load_scene(PENDULUM).simulate(t_end=0.2, n_out=21)
    assert np.array_equal(res.x, ref.x) and np.array_equal(res.t, ref.t)
    assert (out / "vtk" / "pendulum.pvd").exists() and len(list((out / "vtk").glob("*.vtu"))) == 21
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        pass
    else:
        assert (out / "pendulum.png").stat().st_size > 0
    # the tracked tip moves on the unit circle: its chord from the start is 2 sin(|q - q0| / 2)
    chord = 2 * np.sin(np.abs(res.x[:, 0] - res.x[0, 0]) / 2)
    assert summary["points"]["tip"]["max_displacement_m"] == pytest.approx(chord.max(), rel=1e-12)


def test_run_options_override_the_scene(tmp_path, capsys):
    out = tmp_path / "o"
    argv = ["run", FOURBAR, "--out", str(out), "--t-end", "0.1", "--n-out", "5", "--rtol", "1e-6",
            "--complement", "eigen", "--method", "RK45", "--quiet"]
    assert main(argv) == 0
    s = json.loads((out / "summary.json").read_text())
    assert (s["method"], s["complement"], s["n_out"]) == ("RK45", "eigen", 5)
    assert s["max_loop_residual"] < 1e-7


def test_run_takes_method_as_the_scenes_and_the_api_do_and_integrator_as_its_deprecated_alias(tmp_path, capsys):
    """The option is --method, the name of the scene key ([solver] method) and of simulate's argument (issue #32:
    the command said --integrator); --integrator still works, with a note, and contradicting --method is a usage
    error."""
    argv = ["run", PENDULUM, "--t-end", "0.05", "--n-out", "3", "--quiet"]
    assert main(argv + ["--out", str(tmp_path / "m"), "--method", "RK23"]) == 0
    assert "deprecated" not in capsys.readouterr().err
    assert main(argv + ["--out", str(tmp_path / "i"), "--integrator", "RK23"]) == 0
    assert "--integrator is deprecated, use --method" in capsys.readouterr().err
    for name in "mi":
        assert json.loads((tmp_path / name / "summary.json").read_text())["method"] == "RK23"
    with pytest.raises(SystemExit) as usage:
        main(argv + ["--out", str(tmp_path / "x"), "--integrator", "RK23", "--method", "DOP853"])
    assert usage.value.code == 2 and "give --method alone" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--method NAME integrator, as the scene's [solver] method" in text
    assert "--integrator NAME deprecated alias of --method" in text


def interrupt_after(t_stop):
    """A progress bar whose update raises KeyboardInterrupt (Ctrl-C) past ``t_stop`` of simulated time."""

    class Stop:
        def __init__(self, *args, **kw):
            pass

        def update_to(self, t):
            if t > t_stop:
                raise KeyboardInterrupt

        def close(self):
            pass

    return Stop


def test_interrupted_run_writes_what_it_computed(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(STEPPING, "Progress", interrupt_after(0.1))
    out = tmp_path / "partial"
    assert main(["run", PENDULUM, "--out", str(out), "--t-end", "1.0", "--n-out", "101"]) == 130
    assert "interrupted" in capsys.readouterr().err
    res = fm.Result.load(out / "pendulum.npz")
    assert res.status == "interrupted" and 0.1 <= res.t[-1] < 1.0 and len(res.t) > 5
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"
    ref = fm.load_scene(PENDULUM).simulate(t_end=1.0, n_out=101)
    np.testing.assert_allclose(res.x, ref.x[: len(res.t)], rtol=0, atol=1e-12)


@pytest.mark.parametrize("text, where", [
    ("[bodies.bar]\nmass = 1.0\n[solver]\nt_end = = 1\n", "invalid TOML: "),
    ("[bodies.bar]\nmass = -1.0\n[solver]\nt_end = 1.0\n", "bad.toml: bodies.bar.mass: must be > 0"),
    ('[joints.pin]\ntype = "hinge"\n[solver]\nt_end = 1.0\n', "bad.toml: joints.pin.type: no joints plugin"),
])
def test_bad_scene_exits_3_with_one_line(tmp_path, monkeypatch, capsys, text, where):
    monkeypatch.chdir(tmp_path)
    pathlib.Path("bad.toml").write_text(text)
    for cmd in ("run", "info"):
        assert main([cmd, "bad.toml"]) == 3
        err = capsys.readouterr().err
        assert err.startswith("flexmb: error: bad.toml: ") and where in err and err.count("\n") == 1


def test_missing_scene_file_exits_3(tmp_path, capsys):
    assert main(["info", str(tmp_path / "none.toml")]) == 3
    assert "cannot read the scene file" in capsys.readouterr().err


def test_an_unknown_scene_name_lists_the_built_in_scenes(capsys):
    assert main(["run", "wipper", "--out", "unused"]) == 3
    err = capsys.readouterr().err
    assert err == ("flexmb: error: wipper: cannot read the scene file: no such file, and no built-in scene of "
                   "that name (the built-in scenes: bicycle, fourbar, wiper)\n")


def test_builtin_scene_names_still_run(tmp_path, capsys):
    assert main(["run", "fourbar", "--out", str(tmp_path), "--t-end", "0.05", "--n-out", "3", "--quiet"]) == 0
    assert json.loads((tmp_path / "summary.json").read_text())["scene"] == "fourbar"
    assert (tmp_path / "fourbar.npz").exists()


def test_plugins_lists_the_friction_plugin(capsys):
    assert main(["plugins", "--kind", "forces"]) == 0
    assert "velocity_weakening_friction" in capsys.readouterr().out


def test_the_real_command_in_a_subprocess(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(pathlib.Path(fm.__file__).parents[1]),
                                                                     os.environ.get("PYTHONPATH")])))
    ok = subprocess.run([sys.executable, "-m", "flexmb", "info", FOURBAR], capture_output=True, text=True, env=env,
                        cwd=tmp_path)
    assert ok.returncode == 0, ok.stderr
    assert "degrees of freedom: p = n - rank = 1" in ok.stdout
    (tmp_path / "bad.toml").write_text('[joints.pin]\ntype = "revolute"\nparent = "ground"\nchild = "rod"\n'
                                       "[solver]\nt_end = 1.0\n")
    bad = subprocess.run([sys.executable, "-m", "flexmb", "run", "bad.toml"], capture_output=True, text=True,
                         env=env, cwd=tmp_path)
    assert bad.returncode == 3
    assert bad.stderr == "flexmb: error: bad.toml: joints.pin.child: unknown body 'rod'; known: ground\n"


def test_interrupted_builtin_wiper_keeps_the_first_run(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(STEPPING, "Progress", interrupt_after(0.02))
    assert main(["run", "wiper", "--out", str(tmp_path), "--t-end", "0.5", "--n-out", "51"]) == 130
    res = fm.Result.load(tmp_path / "wiper_rigid.npz")
    assert res.status == "interrupted" and 0.02 <= res.t[-1] < 0.5
    assert not (tmp_path / "wiper_flexible.npz").exists()
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "interrupted"


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"flexmb {fm.__version__}"


def test_library_messages_are_silent_unless_logging_is_configured():
    """flexmb's loggers end at a NullHandler: Python's last-resort handler prints nothing of them."""
    code = ("import logging, flexmb; logging.getLogger('flexmb.study').warning('not shown'); "
            "logging.basicConfig(level=logging.INFO, format='%(name)s: %(message)s'); "
            "logging.getLogger('flexmb.study').info('shown')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stderr == "flexmb.study: shown\n"


def test_run_help_lists_every_registered_complement_and_integrator(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for kind in ("complements", "integrators"):
        names = fm.registry.names(kind)
        assert {"svd", "eigen", "qr", "auto"} <= set(names) if kind == "complements" else "IDA" in names
        assert ", ".join(names) in text


def test_docs_list_the_built_in_complements_and_integrators():
    """docs/plugins.md's table and docs/scenes.md name every complement and integrator pyproject.toml registers."""
    import tomllib

    root = pathlib.Path(__file__).resolve().parents[1]
    groups = tomllib.loads((root / "pyproject.toml").read_text())["project"]["entry-points"]
    plugins = (root / "docs" / "plugins.md").read_text()
    scenes = (root / "docs" / "scenes.md").read_text()
    for kind in ("complements", "integrators"):
        row = next(line for line in plugins.splitlines() if line.startswith(f"| `{kind}` |"))
        listed = set(row.rsplit("|", 2)[1].replace("`", "").replace(",", " ").split())
        assert listed == set(groups[f"flexmb.{kind}"]), kind
    synopsis = next(line for line in scenes.splitlines() if line.startswith("flexmb run SCENE.toml"))
    choices = synopsis.split("--complement ")[1].split("]")[0].split("|")
    assert set(choices) == set(groups["flexmb.complements"])
    for name in groups["flexmb.complements"]:
        assert f"`{name}`" in scenes, name
    # the [solver] keys' table: method names every integrator, not only scipy's (issue #32)
    row = next(line for line in scenes.splitlines() if line.startswith("| `method` |"))
    for name in ["auto", *groups["flexmb.integrators"]]:
        assert f"`{name}`" in row, name


# --------------------------------------------------------------------------- the command's exit (cli.console)


def _console(code: str, tmp_path, **kw):
    """Run ``code`` and then :func:`flexmb.cli.console` in a fresh interpreter; the completed process."""
    script = tmp_path / "console.py"
    script.write_text(code + "\nfrom flexmb.cli import console\nconsole()\n")
    return subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300, **kw)


def test_the_command_exits_with_its_output_flushed_and_the_exit_handlers_run(tmp_path):
    proc = _console("import atexit, sys\nsys.argv = ['flexmb', 'plugins']\n"
                    "atexit.register(lambda: print('exit handler ran'))", tmp_path)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("kind") and "CVODE_BDF" in proc.stdout  # the whole listing
    assert lines[-1] == "exit handler ran"


def test_the_command_passes_on_main_s_status(tmp_path):
    proc = _console("import sys\nsys.argv = ['flexmb', 'plugins', '--kind', 'nonsense']", tmp_path)
    assert proc.returncode == 3
    assert "unknown plugin kind 'nonsense'" in proc.stderr


def test_a_thread_still_running_is_let_finish(tmp_path):
    proc = _console("import sys, threading, time\nsys.argv = ['flexmb', '--version']\n"
                    "def late():\n    time.sleep(0.3)\n    print('thread done', flush=True)\n"
                    "threading.Thread(target=late).start()\nsys.argv = ['flexmb', 'plugins', '--kind', 'bodies']",
                    tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "thread done" in proc.stdout.splitlines() and "rigid_body" in proc.stdout


def test_a_reader_that_stops_early_ends_the_command_quietly(tmp_path):
    script = tmp_path / "head.py"
    # flexmb plugins | head -1: the reader closes the pipe after one line
    script.write_text("import subprocess, sys\n"
                      "p = subprocess.Popen([sys.executable, '-m', 'flexmb', 'plugins'], stdout=subprocess.PIPE,\n"
                      "                     stderr=subprocess.PIPE, bufsize=0)\n"
                      "p.stdout.read(10); p.stdout.close()\n"
                      "err = p.stderr.read().decode(); p.wait()\n"
                      "print(p.returncode); print(repr(err))\n")
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    code, err = proc.stdout.splitlines()
    assert code in ("0", "1")  # 0 if the whole listing fitted in the pipe before the reader left
    assert "Traceback" not in err and "BrokenPipeError" not in err


def test_a_run_never_removes_another_scene_s_outputs(tmp_path, monkeypatch, capsys):
    """Issue #32: `flexmb run wiper --out results && flexmb run 01_pendulum.toml` removed the wiper's files.

    Without --out each scene writes to results/<its name>; into a folder holding another scene's outputs
    a run is refused (saying how to overwrite) and removes nothing; --overwrite replaces them.
    """
    monkeypatch.chdir(tmp_path)
    short = ["--t-end", "0.05", "--n-out", "3", "--quiet"]
    assert main(["run", "fourbar", *short]) == 0
    assert main(["run", PENDULUM, *short]) == 0
    assert (tmp_path / "results" / "fourbar" / "fourbar.npz").is_file()
    assert (tmp_path / "results" / "01_pendulum" / "summary.json").is_file()
    capsys.readouterr()
    before = sorted(p.relative_to(tmp_path) for p in (tmp_path / "results" / "fourbar").rglob("*"))
    assert main(["run", PENDULUM, "--out", "results/fourbar", *short]) == 3  # an input error
    err = capsys.readouterr().err
    assert "results/fourbar holds the outputs of scene 'fourbar' (model 'fourbar')" in err and "--overwrite" in err
    assert sorted(p.relative_to(tmp_path) for p in (tmp_path / "results" / "fourbar").rglob("*")) == before
    assert main(["run", "fourbar", "--out", "results/fourbar", *short]) == 0  # the same scene again: replaced
    assert main(["run", PENDULUM, "--out", "results/fourbar", "--overwrite", *short]) == 0
    assert not (tmp_path / "results" / "fourbar" / "fourbar.npz").exists()
    assert json.loads((tmp_path / "results" / "fourbar" / "summary.json").read_text())["scene"] == PENDULUM


def test_run_help_says_where_the_outputs_go(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "default: results/NAME" in text and "--overwrite" in text


def test_exit_statuses_tell_usage_input_failure_and_interruption_apart(tmp_path, monkeypatch, capsys):
    """Issue #32: a typo in the command line, a bad scene and a solver failure all gave 2. Each has its own
    status, documented in --help and docs/scenes.md."""
    with pytest.raises(SystemExit) as usage:
        main(["run", PENDULUM, "--t-ned", "0.1"])  # a typo in an option
    bad = tmp_path / "bad.toml"
    bad.write_text(pathlib.Path(PENDULUM).read_text().replace('type = "revolute"', 'type = "revolut"'))
    code_input = main(["run", str(bad), "--out", str(tmp_path / "bad"), "--quiet"])
    failing = tmp_path / "failing.toml"  # gravity of 1e300 m/s^2: the integrator fails at once
    failing.write_text(pathlib.Path(PENDULUM).read_text().replace("g = [0.0, -9.81, 0.0]", "g = [0.0, -1e300, 0.0]"))
    # (an implicit method: an explicit one is refused before it starts, for the steps it would need)
    code_failed = main(["run", str(failing), "--out", str(tmp_path / "failing"), "--t-end", "0.01", "--quiet",
                        "--method", "CVODE_BDF"])
    assert (tmp_path / "failing" / "summary.json").is_file()  # the partial outputs are written
    monkeypatch.setattr(STEPPING, "Progress", interrupt_after(0.1))  # Ctrl-C at t = 0.1 s
    code_interrupted = main(["run", PENDULUM, "--out", str(tmp_path / "int"), "--t-end", "1.0"])
    codes = (usage.value.code, code_input, code_failed, code_interrupted)
    assert codes == (2, 3, 4, 130)
    from flexmb.cli import EXIT_STATUS

    assert codes == tuple(EXIT_STATUS[k] for k in ("usage", "input", "failed", "interrupted"))
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = capsys.readouterr().out
    docs = (pathlib.Path(__file__).resolve().parents[1] / "docs" / "scenes.md").read_text()
    for what, code in EXIT_STATUS.items():
        assert f"\n  {code:<4} " in text, what
        assert f"| {code} |" in docs, what


def test_a_full_disk_is_one_line_and_exit_5_with_nothing_half_written(tmp_path, monkeypatch, capsys):
    """Disk full (OSError 28) while a run wrote its outputs printed a Python traceback (exit 1)."""
    import errno

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(np, "savez_compressed", full)
    out = tmp_path / "full"
    code = main(["run", PENDULUM, "--out", str(out), "--t-end", "0.05", "--quiet"])
    err = capsys.readouterr().err
    assert code == 5
    assert "flexmb: error: [Errno 28] No space left on device" in err and "Traceback" not in err
    assert not any(p.suffix in (".npz", ".json") for p in out.rglob("*"))  # no result, no summary: nothing half-written
    from flexmb.cli import EXIT_STATUS

    assert EXIT_STATUS["system"] == 5
