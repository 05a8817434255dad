"""The plugin registry: entry-point discovery, lazy loading, errors, session plugins, the CLI listing.

Tested twice, as STYLE.md section 6 asks: once with ``importlib.metadata``
monkeypatched (pluggy ``testing/test_pluginmanager.py`` style fake entry
points), once through real metadata -- flexmb's own installed entry points
and a throw-away distribution built in ``tmp_path``.
"""

from __future__ import annotations

import importlib.metadata
import os
import pathlib
import subprocess
import sys
import textwrap
import tomllib

import numpy as np
import pytest
from scipy.integrate import RK45, OdeSolver, trapezoid

import flexmb as fm
from flexmb import registry
from flexmb.errors import FlexmbError, ModelError, PluginError


#: flexmb's entry points as pyproject.toml declares them: the one list of built-in names
PYPROJECT = tomllib.loads((pathlib.Path(__file__).parents[1] / "pyproject.toml").read_text())
DECLARED = {kind: dict(PYPROJECT["project"]["entry-points"][f"flexmb.{kind}"]) for kind in registry.KINDS}
BUILTIN_NAMES = [(kind, name) for kind, table in DECLARED.items() for name in table]


@pytest.fixture(autouse=True)
def clean_registry(monkeypatch):
    """Each test starts from an empty cache and no session plugins, and leaves none behind."""
    monkeypatch.setattr(registry, "_session", {})
    registry.refresh()
    yield
    registry.refresh()


# --------------------------------------------------------------------------- fake entry points


class FakeDist:
    def __init__(self, name, version):
        self.name, self.version = name, version


class FakeEntryPoint:
    """What ``importlib.metadata.EntryPoint`` offers the registry: name, value, group, dist, load()."""

    def __init__(self, name, value, group, dist, obj=None, exc=None):
        self.name, self.value, self.group, self.dist = name, value, group, dist
        self.obj, self.exc, self.n_loads = obj, exc, 0

    def load(self):
        self.n_loads += 1
        if self.exc is not None:
            raise self.exc
        return self.obj


class Drag(fm.ForceElement):
    """A do-nothing force element standing in for a plugin's class."""


class OtherDrag(fm.ForceElement):
    """A second one, from another distribution."""


@pytest.fixture
def fake_eps(monkeypatch):
    """Install fake entry points beside flexmb's own: ``install(*eps)``; returns the list of groups read.

    ``install(*eps, flexmb=False)`` leaves flexmb's own out, as if flexmb were not installed.
    """
    reads = []
    real = importlib.metadata.entry_points

    class Found(list):
        """What ``importlib.metadata.entry_points()`` offers the registry: ``select(group=...)``."""

        def select(self, **params):
            return Found(e for e in self if all(getattr(e, k) == v for k, v in params.items()))

    def install(*eps, flexmb=True):
        def entry_points(**params):
            reads.append(params.get("group"))
            own = [e for kind in registry.KINDS for e in real(group=f"flexmb.{kind}")
                   if e.dist is not None and e.dist.name == "flexmb"] if flexmb else []
            return Found(own + list(eps)).select(**params)

        monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
        registry.refresh()
        return reads

    return install


def ep(name, value, dist="flexmb-drag", version="1.2", group="flexmb.forces", **kw):
    return FakeEntryPoint(name, value, group, FakeDist(dist, version), **kw)


def test_discovery_records_origin_and_import_path(fake_eps):
    fake_eps(ep("drag", "drag_pkg:Drag", obj=Drag))
    assert "drag" in registry.names("forces")
    info = {p.name: p for p in fm.plugins("forces")}["drag"]
    assert info == fm.PluginInfo("forces", "drag", "drag_pkg:Drag", "flexmb-drag 1.2", "ok", "")
    assert registry.get("forces", "drag") is Drag
    assert registry.get("force", "drag") is Drag  # the singular kind is accepted


def test_loading_is_lazy_and_entry_points_are_read_once(fake_eps):
    plugin = ep("drag", "drag_pkg:Drag", obj=Drag)
    reads = fake_eps(plugin)
    assert registry.names("forces") == sorted(["drag", *DECLARED["forces"]])
    assert plugin.n_loads == 0  # listing names imports nothing
    for _ in range(3):
        assert registry.get("forces", "drag") is Drag
    assert plugin.n_loads == 1
    assert registry.names("joints") == sorted(DECLARED["joints"])
    assert reads == [None]  # one read of all the groups per session
    registry.refresh()
    registry.get("forces", "drag")
    assert reads == [None, None]
    assert plugin.n_loads == 2


def test_broken_plugin_names_itself_and_others_still_load(fake_eps):
    fake_eps(
        ep("bad", "missing_pkg:Bad", dist="flexmb-bad", version="0.1",
           exc=ImportError("No module named 'missing_pkg'")),
        ep("drag", "drag_pkg:Drag", obj=Drag),
    )
    with pytest.raises(PluginError, match=r"'bad' \(missing_pkg:Bad\) from distribution flexmb-bad 0.1 "
                                          r"failed to load: ImportError: No module named 'missing_pkg'") as err:
        registry.get("forces", "bad")
    assert isinstance(err.value.__cause__, ImportError)
    assert isinstance(err.value, FlexmbError)
    assert registry.get("forces", "drag") is Drag
    assert registry.get("forces", "gravity") is fm.Gravity
    rows = {p.name: p for p in fm.plugins("forces")}
    assert rows["bad"].status == "broken" and "missing_pkg" in rows["bad"].error
    assert rows["drag"].status == "ok"


@pytest.mark.parametrize("obj, why", [
    (fm.Revolute, "class flexmb.joints:Revolute; it must be a subclass of flexmb.forces:ForceElement"),
    (len, "a builtin_function_or_method instance, not a class"),
])
def test_object_of_the_wrong_kind_is_refused(fake_eps, obj, why):
    fake_eps(ep("odd", "odd_pkg:odd", dist="flexmb-odd", obj=obj), ep("drag", "drag_pkg:Drag", obj=Drag))
    with pytest.raises(PluginError, match="flexmb-odd") as err:
        registry.get("forces", "odd")
    assert why in str(err.value)
    assert registry.get("forces", "drag") is Drag


def test_name_conflict_between_distributions_names_both(fake_eps):
    fake_eps(
        ep("drag", "drag_pkg:Drag", dist="flexmb-drag", version="1.2", obj=Drag),
        ep("drag", "other_pkg:OtherDrag", dist="other-drag", version="3.0", obj=OtherDrag),
    )
    with pytest.raises(PluginError, match="claimed by 2 distributions") as err:
        registry.get("forces", "drag")
    assert "flexmb-drag 1.2 (drag_pkg:Drag)" in str(err.value)
    assert "other-drag 3.0 (other_pkg:OtherDrag)" in str(err.value)
    rows = [p for p in fm.plugins("forces") if p.name == "drag"]
    assert [(p.origin, p.status) for p in rows] == [("flexmb-drag 1.2", "conflict"), ("other-drag 3.0", "conflict")]
    assert registry.get("forces", "gravity") is fm.Gravity
    # the session can settle it
    fm.register("forces", "drag", OtherDrag, replace=True)
    assert registry.get("forces", "drag") is OtherDrag


def test_path_names_a_plugin_without_importing_it(fake_eps):
    plugin = ep("drag", "drag_pkg:Drag", obj=Drag)
    fake_eps(plugin, ep("twice", "a_pkg:A", dist="a", obj=Drag), ep("twice", "b_pkg:B", dist="b", obj=Drag))
    assert registry.path("forces", "drag") == registry.path("force", "drag") == "drag_pkg:Drag"
    assert plugin.n_loads == 0
    with pytest.raises(PluginError, match="claimed by 2 distributions"):
        registry.path("forces", "twice")
    with pytest.raises(PluginError, match="no forces plugin named 'nope'"):
        registry.path("forces", "nope")
    fm.register("forces", "drag", OtherDrag, replace=True)
    assert registry.path("forces", "drag") == f"{OtherDrag.__module__}:{OtherDrag.__qualname__}"


def test_a_session_replacement_of_cvode_bdf_is_what_simulate_runs(monkeypatch):
    """flexmb's CVODE_BDF runs stepped in compiled code on an open tree; a class registered in its place runs as it is."""
    from flexmb.integrators import CVODEBDF

    monkeypatch.syspath_prepend(str(pathlib.Path(__file__).parents[1] / "benchmarks"))
    import scenes

    made = []

    class Spy(CVODEBDF):
        def __init__(self, *args, **kwargs):
            made.append(self)
            super().__init__(*args, **kwargs)

    system = scenes.b1(2).build()
    res = fm.simulate(system, 0.01, method="CVODE_BDF", n_out=2, progress=False)
    assert res.status == "finished" and made == []
    fm.register("integrators", "CVODE_BDF", Spy, replace=True)
    res = fm.simulate(system, 0.01, method="CVODE_BDF", n_out=2, progress=False)
    assert res.status == "finished" and len(made) == 1


def test_one_distribution_found_twice_is_not_a_conflict(fake_eps):
    # e.g. an egg-info in the working directory and the dist-info in site-packages
    fake_eps(ep("drag", "drag_pkg:Drag", dist="flexmb_drag", obj=Drag),
             ep("drag", "drag_pkg:Drag", dist="flexmb-drag", obj=Drag))
    assert registry.get("forces", "drag") is Drag
    assert [p.status for p in fm.plugins("forces") if p.name == "drag"] == ["ok"]


def test_without_flexmb_metadata_a_lookup_says_to_install(fake_eps):
    fake_eps(ep("drag", "drag_pkg:Drag", obj=Drag), flexmb=False)  # flexmb not installed: only another plugin
    for lookup in (fm.plugins, lambda: registry.get("joints", "revolute"), lambda: len(fm.COMPLEMENTS)):
        with pytest.raises(PluginError, match=r"flexmb is not installed.*pip install -e \."):
            lookup()


def test_register_for_the_session():
    class Mine(fm.SVDComplement):
        name = "mine"

    fm.register("complements", "mine", Mine)
    assert registry.get("complements", "mine") is Mine
    assert isinstance(fm.get_complement("mine"), Mine)
    row = {p.name: p for p in fm.plugins("complements")}["mine"]
    assert (row.origin, row.status, row.value) == ("session", "ok", f"{__name__}:{Mine.__qualname__}")

    with pytest.raises(PluginError, match="already exists.*session.*replace=True"):
        fm.register("complements", "mine", Mine)

    class Mine2(Mine):
        pass

    fm.register("complement", "mine", Mine2, replace=True)
    assert registry.get("complements", "mine") is Mine2
    registry.refresh()  # re-reading entry points keeps the session's plugins
    assert registry.get("complements", "mine") is Mine2


def test_register_refuses_bad_input():
    with pytest.raises(PluginError, match=r"already exists \(from flexmb"):
        fm.register("forces", "gravity", Drag)
    with pytest.raises(PluginError, match="must be a subclass of flexmb.joints:Joint"):
        fm.register("joints", "drag", Drag)
    with pytest.raises(PluginError, match="instance, not a class"):
        fm.register("complements", "inst", fm.SVDComplement())
    with pytest.raises(PluginError, match="non-empty string"):
        fm.register("forces", "", Drag)
    with pytest.raises(PluginError, match=r"unknown plugin kind 'solvers'; pick one of \['bodies'"):
        fm.register("solvers", "x", Drag)
    fm.register("forces", "gravity", Drag, replace=True)
    assert registry.get("forces", "gravity") is Drag


def test_unknown_names_list_the_valid_ones():
    with pytest.raises(PluginError, match=r"no joints plugin named 'hinge'; pick one of \['cylindrical'"):
        registry.get("joints", "hinge")
    pattern = r"unknown complement strategy 'lu'; pick one of \['articulated', 'auto', 'eigen', 'qr', 'svd'\]"
    with pytest.raises(ModelError, match=pattern):
        fm.get_complement("lu")
    with pytest.raises(ModelError, match=r"unknown integrator 'Euler'; pick one of \['BDF', 'DOP853'"):
        fm.simulate(_pendulum(), 0.1, method="Euler")


def _pendulum(*extra):
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -9.81, 0.0)))
    for make in extra:
        model.add(make(bar))
    return model


def test_simulate_takes_a_registered_integrator():
    class MyRK(RK45):
        pass

    fm.register("integrators", "MyRK", MyRK)
    res = fm.simulate(_pendulum(), 0.2, method="MyRK", positions={"pin": 0.5}, n_out=5)
    assert res.status == "finished" and res.method == "MyRK"


def test_import_flexmb_reads_no_entry_points():
    code = textwrap.dedent("""
        import importlib.metadata as md
        import sys
        real, readers = md.entry_points, []

        def spy(*args, **kwargs):  # who reads entry points (numba reads its extensions' too)
            readers.append(sys._getframe(1).f_globals.get("__name__"))
            return real(*args, **kwargs)
        md.entry_points = spy
        import flexmb
        assert "flexmb.registry" not in readers, readers
        flexmb.registry.get("joints", "revolute")
        assert "flexmb.registry" in readers, readers
        print("lazy")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "lazy"


# --------------------------------------------------------------------------- real installed metadata

def _flexmb_entry_points(kind):
    return {e.name: e.value for e in importlib.metadata.entry_points(group=f"flexmb.{kind}")
            if e.dist is not None and e.dist.name == "flexmb"}


def _import(value):
    module, _, qualname = value.partition(":")
    obj = importlib.import_module(module)
    for attr in qualname.split("."):
        obj = getattr(obj, attr)
    return obj


@pytest.mark.parametrize("kind, name", BUILTIN_NAMES)
def test_every_builtin_resolves_through_installed_metadata(kind, name):
    assert registry.get(kind, name) is _import(DECLARED[kind][name])


@pytest.mark.parametrize("kind", list(DECLARED))
def test_installed_entry_points_are_the_ones_pyproject_declares(kind):
    installed = _flexmb_entry_points(kind)
    assert installed, f"no flexmb.{kind} entry points installed: rerun `pip install -e .`"
    assert installed == DECLARED[kind], "the installed metadata is stale: rerun `pip install -e .`"
    assert {p.origin for p in fm.plugins(kind) if p.name in installed} == {f"flexmb {fm.__version__}"}
    base = registry._base(kind)
    assert all(issubclass(_import(value), base) for value in DECLARED[kind].values())
    assert registry._base("integrators") is OdeSolver
    assert dict(registry.builtin_table(kind)) == {name: _import(value) for name, value in DECLARED[kind].items()}


def test_complements_and_integrators_are_read_only_views_of_the_builtins():
    for table, kind in ((fm.COMPLEMENTS, "complements"), (fm.INTEGRATORS, "integrators")):
        assert table == {name: _import(value) for name, value in DECLARED[kind].items()}
        assert sorted(table) == sorted(DECLARED[kind]) and len(table) == len(DECLARED[kind])
        with pytest.raises(TypeError):
            table["mine"] = fm.SVDComplement
        with pytest.raises(KeyError):
            table["no such method"]
    assert fm.COMPLEMENTS["svd"] is fm.SVDComplement and fm.INTEGRATORS["RK45"] is RK45


def test_session_plugins_stay_out_of_the_builtin_views():
    class Mine(fm.SVDComplement):
        """A session strategy."""

    registry.register("complements", "mine", Mine)
    registry.register("complements", "svd", Mine, replace=True)
    assert "mine" not in fm.COMPLEMENTS and fm.COMPLEMENTS["svd"] is fm.SVDComplement
    assert registry.get("complements", "svd") is Mine


def _cli_plugins(tmp_path, pythonpath=None):
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(pythonpath), env.get("PYTHONPATH")]))
    out = subprocess.run([sys.executable, "-m", "flexmb", "plugins"], capture_output=True, text=True,
                         cwd=tmp_path, env=env, timeout=60)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0].split() == ["kind", "name", "origin", "status"]
    return {(ln.split()[0], ln.split()[1]): ln.split()[2:] for ln in lines[1:] if ln.strip()}


def test_cli_lists_the_builtins(tmp_path):
    assert BUILTIN_NAMES
    rows = _cli_plugins(tmp_path)
    for key in BUILTIN_NAMES:
        assert rows[key] == ["flexmb", fm.__version__, "ok"], key


# --------------------------------------------------------------------------- a throw-away plugin distribution

DRAG_MODULE = '''
"""A linear drag force -c v at a body point: a third-party force element."""
import numpy as np
from attrs import field, frozen

import flexmb as fm


@frozen(eq=False)
class LinearDrag(fm.ForceElement):
    body: fm.Body = field()
    c: float = field(default=0.0)
    point: tuple = field(default=(0.0, 0.0, 0.0))

    def apply(self, state, loads):
        k, local = state.locate(self.body, np.asarray(self.point, dtype=float))
        p = state.point_position(k, local)
        loads.add_point_force(k, p, -self.c * state.point_velocity(k, p))
'''


@pytest.fixture
def drag_dist(tmp_path, monkeypatch):
    """A distribution 'flexmb-drag' 0.3.1 with entry point linear_drag = mydrag:LinearDrag, on sys.path."""
    site = tmp_path / "site"
    info = site / "flexmb_drag-0.3.1.dist-info"
    info.mkdir(parents=True)
    (site / "mydrag.py").write_text(DRAG_MODULE)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: flexmb-drag\nVersion: 0.3.1\n")
    (info / "entry_points.txt").write_text("[flexmb.forces]\nlinear_drag = mydrag:LinearDrag\n")
    monkeypatch.syspath_prepend(str(site))
    yield site
    sys.modules.pop("mydrag", None)


def test_throwaway_plugin_is_discovered_and_removes_energy(drag_dist):
    registry.refresh()
    assert "linear_drag" in registry.names("forces")
    assert "mydrag" not in sys.modules  # found, not yet imported
    LinearDrag = registry.get("forces", "linear_drag")
    assert LinearDrag.__name__ == "LinearDrag" and issubclass(LinearDrag, fm.ForceElement)
    assert {p.name: p.origin for p in fm.plugins("forces")}["linear_drag"] == "flexmb-drag 0.3.1"

    c, tip = 0.3, (1.0, 0.0, 0.0)
    free = fm.simulate(_pendulum(), 2.0, positions={"pin": 1.0}, n_out=401)
    damped = fm.simulate(_pendulum(lambda bar: LinearDrag("drag", bar, c, tip)), 2.0, positions={"pin": 1.0},
                         n_out=401)
    assert np.ptp(free.energy) < 1e-6 * abs(free.energy[0])
    assert np.all(np.diff(damped.energy) < 1e-9)
    # power balance: the energy lost is the work of the drag, c |v_tip|^2 = c (L theta')^2 integrated
    theta_dot = damped.xd[:, 0]
    dissipated = trapezoid(c * theta_dot**2, damped.t)
    lost = damped.energy[0] - damped.energy[-1]
    assert lost > 0.05 * abs(damped.energy[0] - damped.potential.min())
    assert lost == pytest.approx(dissipated, rel=2e-3)


def test_cli_lists_the_throwaway_plugin(drag_dist, tmp_path):
    rows = _cli_plugins(tmp_path, pythonpath=drag_dist)
    assert rows[("forces", "linear_drag")] == ["flexmb-drag", "0.3.1", "ok"]
    assert rows[("joints", "revolute")] == ["flexmb", fm.__version__, "ok"]
