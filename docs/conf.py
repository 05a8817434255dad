"""Sphinx configuration for the flexmb documentation.

Build with warnings as errors (as CI does)::

    python -m pip install -e ".[docs]"
    python -m sphinx -W -q docs docs/_build

The markdown pages in ``docs/`` are read by MyST as they are. Two things
are generated at build time, into folders that git ignores:

* ``docs/generated/``: one autosummary page per public name of
  ``flexmb.__all__`` (``api.rst``);
* ``docs/tutorials/``: the tutorials' gallery (sphinx-gallery): every
  ``tutorials/NN_*.py`` script is run, its docstring and comments become
  the text and its printed output and figures appear below its code (all
  of them take under a minute; ``tests/test_tutorials.py`` checks their
  numbers).

Pages that other parts of the project add later (``scenes.md``,
``stresses.md``, ``stability.md``, ``benchmarks.md``, or any other
``docs/*.md``) join the table of contents of ``index.md`` automatically,
at the ``<!-- more-pages -->`` marker, if and only if they exist, so the
build neither breaks when they are missing nor warns about a page outside
every toctree when they appear.
"""

from __future__ import annotations

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
    "sphinx_gallery.gen_gallery",
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
LATER_PAGES = ["scenes", "stresses", "linear", "stability", "benchmarks"]
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
# The tutorials: sphinx-gallery runs every ``tutorials/NN_*.py`` script (its
# ``if __name__ == "__main__"`` block included) and shows its text, code,
# printed output and figures; ``tests/test_tutorials.py`` checks their numbers.
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "tutorials"),
    "gallery_dirs": str(DOCS / "tutorials"),
    "filename_pattern": r"/\d\d_",
    "ignore_pattern": r"__init__\.py",
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": True,
    "download_all_examples": False,
    "show_signature": False,
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "run_stale_examples": False,
}


def setup(app):
    app.connect("source-read", _insert_pages)
    app.connect("env-get-outdated", _reread_index)
    return {"parallel_read_safe": True}
