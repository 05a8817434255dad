"""Sphinx configuration for the flexmb documentation.

Build with warnings as errors (as CI does)::

    python -m pip install -e ".[docs]"
    python -m sphinx -W -q docs docs/_build

The markdown pages in ``docs/`` are read by MyST as they are. Two things
are generated at build time, into folders that git ignores:

* ``docs/generated/``: one autosummary page per public name of
  ``flexmb.__all__`` (``api.rst``);
* ``docs/tutorials/``: one page per ``tutorials/NN_*.py`` script, its module
  docstring as the text and the script itself as a listing. The tutorials
  are not executed here (the wiper alone takes half a minute); CI runs them
  in ``tests/test_tutorials.py``.

Pages that other parts of the project add later (``scenes.md``,
``stresses.md``, ``stability.md``, ``benchmarks.md``, or any other
``docs/*.md``) join the table of contents of ``index.md`` automatically,
at the ``<!-- more-pages -->`` marker, if and only if they exist, so the
build neither breaks when they are missing nor warns about a page outside
every toctree when they appear.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

import attrs

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "plugins"))

import flexmb  # noqa: E402

project = "flexmb"
author = "the flexmb developers"
copyright = "2026, the flexmb developers"
release = version = flexmb.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_templates", "Thumbs.db", ".DS_Store", "README.md"]
templates_path = ["_templates"]

myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

html_theme = "alabaster"
html_title = f"flexmb {release}"

autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
autodoc_member_order = "bysource"

numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# Every docstring the build renders is validated; a failed check is a
# warning, so an error under -W. The same set is checked over the whole
# public API by tests/test_docstrings.py (which keeps the two sets equal).
numpydoc_validation_checks = {"GL08", "SS01", "SS02", "SS03", "SS04", "PR01", "PR02", "PR07", "PR10", "RT01", "RT03"}

# The name tables are dicts: autodata shows their value, and they have no
# docstring of their own to validate (api.rst describes them).
numpydoc_validation_exclude = {r"^flexmb\.(COMPLEMENTS|INTEGRATORS)$"}


def _attrs_fields() -> dict[str, list[str]]:
    """The attrs fields of every public attrs class, by each dotted name it has in an ``__all__``.

    The class template (``_templates/autosummary/class.rst``) leaves them out
    of the attribute tables: they are documented in the class's Parameters
    section, and as slots they have no docstring of their own.
    """
    import importlib
    import pkgutil

    out = {}
    modules = ["flexmb"] + [m.name for m in pkgutil.walk_packages(flexmb.__path__, "flexmb.")
                            if not any(part.startswith("_") for part in m.name.split("."))]
    for modname in modules:
        module = importlib.import_module(modname)
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            if isinstance(obj, type) and attrs.has(obj):
                out[f"{modname}.{name}"] = [f.name for f in attrs.fields(obj)]
    return out


autosummary_context = {"attrs_fields": _attrs_fields()}

# Markdown links to files outside the Sphinx source (tutorial scripts,
# benchmarks/, pyproject.toml) are fine on GitHub; Sphinx cannot resolve
# them, so they are not checked as cross-references.
suppress_warnings = ["myst.xref_missing"]

# ---------------------------------------------------------------------------
# The pages the index links in a fixed order; anything else in docs/*.md is
# appended after them. Other engineers' pages are listed here in the order
# they should appear once they exist.
FIXED_PAGES = ["getting_started", "guide", "tutorials/index", "theory", "export", "plugins", "validation",
               "api"]
LATER_PAGES = ["scenes", "stresses", "stability", "benchmarks"]
MARKER = "<!-- more-pages -->"


def more_pages() -> list[str]:
    """The existing pages not in ``FIXED_PAGES``: the known later pages first, then any other ``docs/*.md``."""
    present = {p.stem for p in DOCS.glob("*.md")} | {p.stem for p in DOCS.glob("*.rst")}
    present -= set(FIXED_PAGES) | {"index"}
    ordered = [p for p in LATER_PAGES if p in present]
    return ordered + sorted(present - set(ordered))


def _insert_pages(app, docname, source):
    if docname == "index" and MARKER in source[0]:
        source[0] = source[0].replace(MARKER, "\n".join(more_pages()))


def _reread_index(app, env, added, changed, removed):
    # the index's toctree depends on which pages exist, not only on its own text
    return ["index"]


# ---------------------------------------------------------------------------
# One page per tutorial script.
TUTORIALS = ROOT / "tutorials"
TUTORIAL_PAGES = DOCS / "tutorials"


def _tutorial_page(script: Path) -> str:
    tree = ast.parse(script.read_text(encoding="utf-8"))
    doc = ast.get_docstring(tree) or script.stem
    # the listing starts after the module docstring, which is the page's text
    first = tree.body[0].end_lineno + 1 if ast.get_docstring(tree) else 1
    lines = doc.strip().splitlines()
    # the sphinx-gallery title: a line underlined with '='
    if len(lines) > 1 and re.fullmatch(r"=+", lines[1].strip()):
        title, body = lines[0].strip(), "\n".join(lines[2:]).strip()
    else:
        title, body = script.stem, "\n".join(lines)
    rel = Path("..", "..", "tutorials", script.name).as_posix()
    return (f"{title}\n{'=' * len(title)}\n\n"
            f"``tutorials/{script.name}``: run it with ``python tutorials/{script.name}`` from the "
            "repository root; its pictures go to ``results/``.\n\n"
            f"{body}\n\n"
            "The script\n----------\n\n"
            f".. literalinclude:: {rel}\n   :language: python\n   :lines: {first}-\n"
            f"   :lineno-start: {first}\n")


def write_tutorial_pages() -> list[str]:
    """Write ``docs/tutorials/<script>.rst`` for every tutorial and the index; return the page names."""
    TUTORIAL_PAGES.mkdir(exist_ok=True)
    names = []
    for script in sorted(TUTORIALS.glob("[0-9][0-9]_*.py")):
        page = TUTORIAL_PAGES / f"{script.stem}.rst"
        text = _tutorial_page(script)
        if not page.exists() or page.read_text(encoding="utf-8") != text:
            page.write_text(text, encoding="utf-8")
        names.append(script.stem)
    for stale in TUTORIAL_PAGES.glob("[0-9][0-9]_*.rst"):
        if stale.stem not in names:
            stale.unlink()
    index = ("Tutorials\n=========\n\n"
             "Runnable scripts in ``tutorials/``, each tested in CI (``tests/test_tutorials.py`` runs it and "
             "checks its numbers). Each states what you should see and the numbers to expect.\n\n"
             ".. toctree::\n   :maxdepth: 1\n\n" + "".join(f"   {n}\n" for n in names))
    path = TUTORIAL_PAGES / "index.rst"
    if not path.exists() or path.read_text(encoding="utf-8") != index:
        path.write_text(index, encoding="utf-8")
    return names


write_tutorial_pages()


def setup(app):
    app.connect("source-read", _insert_pages)
    app.connect("env-get-outdated", _reread_index)
    return {"parallel_read_safe": True}
