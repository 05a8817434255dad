"""The plugin group ``flexmb.contacts``: docs/plugins.md's worked example (a geometry and a law), installed
through a real entry point, used from a scene file and listed by ``flexmb plugins``.

Closed form: a box of mass m resting flat on the plane on its four lower
corners (points), each under a Hertz law ``F = K delta^(3/2)``: each
carries ``m g / 4`` at the penetration ``(m g / (4 K))^(2/3)``; the upper
corners are ``2 h`` above the plane.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import flexmb as fm
from flexmb import registry

DOCS = Path(__file__).resolve().parents[1] / "docs"
M, G, HX, HY, HZ, PAD = 3.0, 9.81, 0.2, 0.1, 0.05, 0.01


def _worked_example() -> str:
    """The ``# mycontacts.py`` code block of docs/plugins.md, as the reader copies it."""
    text = (DOCS / "plugins.md").read_text(encoding="utf-8")
    block = re.search(r"```python\n(# mycontacts\.py\n.*?)```", text, re.S)
    assert block, "docs/plugins.md lost its contact plugin example"
    return block.group(1)


@pytest.fixture
def contacts_dist(tmp_path, monkeypatch):
    """A distribution 'flexmb-contacts' 1.0 declaring docs/plugins.md's box and law in the group flexmb.contacts."""
    site = tmp_path / "site"
    info = site / "flexmb_contacts-1.0.dist-info"
    info.mkdir(parents=True)
    (site / "mycontacts.py").write_text(_worked_example())
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: flexmb-contacts\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(
        "[flexmb.contacts]\nbox_plane = mycontacts:BoxPlaneContact\nsteel_pad = mycontacts:SteelPadLaw\n")
    monkeypatch.syspath_prepend(str(site))
    registry.refresh()
    yield site
    sys.modules.pop("mycontacts", None)
    registry.refresh()


SCENE = f"""
[model]
name = "crate"

[bodies.crate]
mass = {M}
inertia = [0.01, 0.04, 0.05]

[joints.free]
type = "free"
parent = "ground"
child = "crate"

[forces.gravity]
type = "gravity"
g = [0.0, 0.0, -{G}]

[forces.floor]
type = "box_plane"
body = "crate"
half_extents = [{HX}, {HY}, {HZ}]
normal_law = {{type = "steel_pad", radius = {PAD}, restitution = 0.6}}

[solver]
t_end = 0.01
"""


def test_a_contact_plugin_is_found_through_its_entry_point_and_used_from_a_scene(contacts_dist):
    assert {"box_plane", "steel_pad"} <= set(registry.names("contacts")) and "mycontacts" not in sys.modules
    scene = fm.loads_scene(SCENE)
    system = scene.system()
    floor = scene.model.element("floor")
    assert type(floor).__module__ == "mycontacts"
    K = fm.hertz_stiffness(PAD, 2.1e11, 0.3, np.inf, 2.1e11, 0.3)
    depth = (M * G / (4 * K)) ** (2 / 3)
    x = np.array([0.0, 0.0, HZ - depth, 0.0, 0.0, 0.0])
    kin = system.kinematics(0.0, x, np.zeros(6))
    # at rest on its lower corners: the plane carries the weight, nothing turns it
    np.testing.assert_allclose(system.forces.active_force(kin), 0.0, atol=1e-9 * M * G)
    delta, _, fn, _, _, _, _, _ = type(floor).row_states([floor], kin)
    lower = delta > 0
    assert lower.sum() == 4
    np.testing.assert_allclose(fn[lower], M * G / 4, rtol=1e-9)
    np.testing.assert_allclose(delta[~lower], depth - 2 * HZ, rtol=1e-12)
    # the element reports one contact: the weight, at the box's centre's shadow
    _, _, total, _, point, _, _, _ = type(floor).states_all([floor], kin)
    assert total[0] == pytest.approx(M * G, rel=1e-9)
    np.testing.assert_allclose(point[0, :2], 0.0, atol=1e-12)


def test_flexmb_plugins_lists_the_contacts_with_their_distribution(contacts_dist):
    rows = {(p.name, p.origin, p.status) for p in fm.plugins("contacts")}
    assert {("box_plane", "flexmb-contacts 1.0", "ok"), ("steel_pad", "flexmb-contacts 1.0", "ok"),
            ("capsule_capsule_contact", f"flexmb {fm.__version__}", "ok"),
            ("flores", f"flexmb {fm.__version__}", "ok")} <= rows
    out = subprocess.run([sys.executable, "-m", "flexmb", "plugins", "--kind", "contacts"], capture_output=True,
                         text=True, check=True, env={**__import__("os").environ,
                                                     "PYTHONPATH": str(contacts_dist)}).stdout
    lines = {tuple(line.split()) for line in out.splitlines()}
    assert ("contacts", "box_plane", "flexmb-contacts", "1.0", "ok") in lines
    assert ("contacts", "contact_group", "flexmb", fm.__version__, "ok") in lines


def test_a_law_of_another_kind_is_refused_by_name(contacts_dist):
    with pytest.raises(fm.ModelError, match=r"'floor'.*friction: a law's table needs type = one of 'coulomb'.*"
                                            r"got 'steel_pad'"):
        fm.SpherePlaneContact("floor", "ball", 0.1, {"type": "steel_pad", "radius": 0.01, "restitution": 0.5},
                              friction={"type": "steel_pad"})
