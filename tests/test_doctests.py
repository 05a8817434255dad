"""The docstrings' Examples run, and the documentation names only what exists.

* Every module of the package is run through :mod:`doctest` (the Examples
  sections of the docstrings); plugins registered by an example are
  forgotten afterwards.
* The key public classes carry an Examples section.
* Every dotted ``flexmb.…`` name on the theory page (``docs/theory.md``,
  which maps the paper's equations to the code) resolves to a real module,
  class, function or attribute.
* The API page (``docs/api.rst``) lists every name of ``flexmb.__all__``.
"""

from __future__ import annotations

import doctest
import importlib
import inspect
import pathlib
import pkgutil
import re

import numpy as np
import pytest

import flexmb
from flexmb import registry

DOCS = pathlib.Path(__file__).resolve().parents[1] / "docs"
MODULES = sorted(m.name for m in pkgutil.walk_packages(flexmb.__path__, "flexmb.") if m.name != "flexmb.__main__")
# modules whose public classes must show a runnable example
WITH_EXAMPLES = ["flexmb.bodies", "flexmb.joints", "flexmb.sections", "flexmb.flexible", "flexmb.drivers",
                 "flexmb.forces.base", "flexmb.forces.gravity", "flexmb.forces.springs", "flexmb.forces.loads",
                 "flexmb.model"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name, monkeypatch):
    monkeypatch.setattr(registry, "_session", {})  # an example may register a plugin for the session
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in finder.find(module, name):
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples in {name} failed (see output)"
    if name in WITH_EXAMPLES:
        assert result.attempted > 0, f"{name} has no runnable example"


@pytest.mark.parametrize("name", [
    "ForceElement", "Gravity", "SpringDamper", "JointSpringDamper", "PointForce", "BodyTorque",
    "Joint", "Revolute", "Prismatic", "Universal", "RigidBody", "FlexibleBody", "Section", "Material",
    "Driver", "Model", "simulate", "modes", "EigenComplement", "SVDComplement",
])
def test_key_public_names_have_examples(name):
    doc = inspect.getdoc(getattr(flexmb, name))
    assert re.search(r"^Examples\n-{8}\n", doc, re.M), f"flexmb.{name} has no Examples section"
    assert ">>> " in doc.split("Examples", 1)[1]


def _resolve(dotted: str):
    """Import the longest module prefix of ``dotted`` and get the rest as attributes."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(dotted)


def test_theory_page_names_exist():
    text = (DOCS / "theory.md").read_text(encoding="utf-8")
    names = sorted(set(re.findall(r"`(flexmb(?:\.\w+)+)`", text)))
    assert len(names) >= 20
    missing = []
    for dotted in names:
        try:
            _resolve(dotted)
        except (ImportError, AttributeError):
            missing.append(dotted)
    assert not missing, f"docs/theory.md names what does not exist: {missing}"
    # every equation row says where it is implemented, with at least one real name
    rows = [line for line in text.splitlines() if re.match(r"\| \(\d+\)", line)]
    assert len(rows) >= 12
    for row in rows:
        assert re.search(r"`flexmb\.\w+", row.split("|")[3]), row


def test_kinematics_attributes_named_by_theory_exist():
    # the theory page names Kinematics attributes set in __init__; check them on a real state
    model = flexmb.Model()
    bar = flexmb.RigidBody.slender_bar("bar", 1.0, 1.0)
    system = model.add(flexmb.Revolute("pin", model.ground, bar)).build()
    kin = system.kinematics(0.0, np.zeros(1), np.ones(1))
    for attr in ("W", "omega", "alpha_bias", "a_bias", "r", "v", "V"):
        assert f"`{attr}`" in (DOCS / "theory.md").read_text(encoding="utf-8")
        assert getattr(kin, attr).shape[0] == 2


def test_api_page_lists_every_public_name():
    text = (DOCS / "api.rst").read_text(encoding="utf-8")
    listed = set(re.findall(r"^ {3}(\w+)$", text, re.M))
    missing = sorted(set(flexmb.__all__) - listed)
    assert not missing, f"docs/api.rst does not list {missing}"
