"""The plugin group ``flexmb.constraints``, installed through a real entry point and used from a scene file.

The elements are the ones the docs give a reader, taken from where they are
written: tutorial 12's gear pair (its ``tutorial_gears.py`` module and its
gear-train scene, read from ``tutorials/12_velocity_constraints.py``
without running it) and docs/plugins.md's slipping belt (its ``# mygears.py``
code block), one distribution declaring both.
"""

from __future__ import annotations

import ast
import re
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import flexmb as fm
from flexmb import registry

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = ROOT / "tutorials" / "12_velocity_constraints.py"


def _worked_example() -> str:
    """The ``# mygears.py`` code block of docs/plugins.md, as the reader copies it."""
    text = (ROOT / "docs" / "plugins.md").read_text(encoding="utf-8")
    block = re.search(r"```python\n(# mygears\.py\n.*?)```", text, re.S)
    assert block, "docs/plugins.md lost its constraint element example"
    return block.group(1)


def _tutorial_values(*names) -> dict:
    """The values tutorial 12 assigns to ``names`` at module level, its other statements not run."""
    tree = ast.parse(TUTORIAL.read_text(encoding="utf-8"))
    ns = {"textwrap": textwrap}
    for node in tree.body:
        targets = [t for a in (node.targets if isinstance(node, ast.Assign) else []) for t in ast.walk(a)
                   if isinstance(t, ast.Name)]
        if any(t.id in names for t in targets):
            exec(compile(ast.Module([node], type_ignores=[]), str(TUTORIAL), "exec"), ns)  # noqa: S102
    missing = [n for n in names if n not in ns]
    assert not missing, f"tutorial 12 no longer assigns {missing}"
    return ns


TUTORIAL_GEARS = _tutorial_values("PLUGIN", "SCENE", "I1", "I2", "K", "N")
I1, I2, K, N = (TUTORIAL_GEARS[k] for k in ("I1", "I2", "K", "N"))


@pytest.fixture
def gears_dist(tmp_path, monkeypatch):
    """A distribution 'flexmb-gears' 1.0 declaring tutorial 12's gear pair and docs/plugins.md's belt."""
    site = tmp_path / "site"
    info = site / "flexmb_gears-1.0.dist-info"
    info.mkdir(parents=True)
    (site / "tutorial_gears.py").write_text(TUTORIAL_GEARS["PLUGIN"])
    (site / "mygears.py").write_text(_worked_example())
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: flexmb-gears\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(
        "[flexmb.constraints]\nuser_gear_pair = tutorial_gears:UserGearPair\nslipping_belt = mygears:SlippingBelt\n")
    monkeypatch.syspath_prepend(str(site))
    registry.refresh()
    yield site
    for module in ("tutorial_gears", "mygears"):
        sys.modules.pop(module, None)
    registry.refresh()


I3, I4, R3, R4, S0, F = 0.3, 0.1, 0.2, 0.05, 0.1, 4.0

# tutorial 12's gear train, with two pulleys on a slipping belt beside it (its [initial] sets no speeds)
SCENE = TUTORIAL_GEARS["SCENE"] + f"""
[bodies.pulley3]
mass = 1.0
inertia = [{I3}, {I3}, {I3}]
[bodies.pulley4]
mass = 1.0
inertia = [{I4}, {I4}, {I4}]

[joints.shaft3]
type = "revolute"
parent = "ground"
child = "pulley3"
[joints.shaft4]
type = "revolute"
parent = "ground"
child = "pulley4"

[constraints.belt]
type = "slipping_belt"
pulley1 = "shaft3"
pulley2 = "shaft4"
r1 = {R3}
r2 = {R4}
s0 = {S0}
f = {F}

[initial.speeds]
shaft3 = 2.0
"""


def test_a_constraint_plugin_is_found_through_its_entry_point_and_used_from_a_scene(gears_dist):
    """Gears ``q1 = n q2`` with a spring k on shaft 1: ``q1 = A cos(w t)``, ``w = sqrt(k / (I1 + I2 / n^2))``.

    Belt ``r3 w3 - r4 w4 = s(t)``: its force acts as ``r3 lambda`` on pulley 3
    and ``-r4 lambda`` on pulley 4, so ``P = I3 w3 / r3 + I4 w4 / r4`` is
    conserved and ``w3 = (P + I4 s / r4^2) / (I3 / r3 + I4 r3 / r4^2)``.
    """
    assert "user_gear_pair" in registry.names("constraints") and "tutorial_gears" not in sys.modules
    assert {p.name: p.origin for p in fm.plugins("constraints")}["slipping_belt"] == "flexmb-gears 1.0"
    scene = fm.loads_scene(SCENE)
    assert scene.model.element("mesh").__class__.__name__ == "UserGearPair"
    res = scene.simulate()
    names = res.coordinate_names
    q = {j: res.x[:, names.index(f"{j}.angle")] for j in ("shaft1", "shaft2", "shaft3", "shaft4")}
    w = {j: res.xd[:, names.index(f"{j}.angle")] for j in ("shaft1", "shaft2", "shaft3", "shaft4")}
    assert res.constraint_labels == ["mesh.mesh", "belt.0"]
    assert np.max(np.abs(q["shaft1"] - N * q["shaft2"])) < 1e-10
    omega = np.sqrt(K / (I1 + I2 / N**2))
    assert np.max(np.abs(q["shaft1"] - 0.4 * np.cos(omega * res.t))) < 1e-7
    s = S0 * np.sin(F * res.t)
    assert np.max(np.abs(R3 * w["shaft3"] - R4 * w["shaft4"] - s)) < 1e-9
    P = I3 * 2.0 / R3 + I4 * (R3 * 2.0 / R4) / R4
    w3 = (P + I4 * s / R4**2) / (I3 / R3 + I4 * R3 / R4**2)
    assert np.max(np.abs(w["shaft3"] - w3)) < 1e-8
    assert np.ptp(w["shaft3"]) > 0.1  # the slip moves it: the check can fail


def test_a_scene_names_an_unknown_constraint_plugin(gears_dist):
    with pytest.raises(fm.SceneError, match=r"constraints\.mesh\.type.*no_such_gear"):
        fm.loads_scene(SCENE.replace('type = "user_gear_pair"', 'type = "no_such_gear"'))
    with pytest.raises(fm.SceneError, match=r"constraints\.mesh"):
        fm.loads_scene(SCENE.replace('joint2 = "shaft2"', 'joint2 = "shaft9"'))
