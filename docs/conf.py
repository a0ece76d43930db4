"""Sphinx configuration of the nh-operators site: ``make docs`` builds it."""

import os
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))  # gallery_scrapers, architecture_page
sys.path.insert(0, str(DOCS.parent))  # the package of this checkout

# The tutorials run headless; nh_operators selects DeepXDE's PyTorch backend itself.
os.environ.setdefault("DDE_BACKEND", "pytorch")
os.environ.setdefault("MPLBACKEND", "Agg")

import nh_operators  # noqa: E402

project = "nh-operators"
author = "nh-operators contributors"
copyright = "nh-operators contributors"
release = nh_operators.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "architecture_page",  # docs/architecture.rst: the wings drawn from the imports
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
templates_path = ["_templates"]

# -- API reference: Google-style docstrings (Args:, Returns:, Raises:) ---------------
autosummary_generate = True
autosummary_imported_members = False
autodoc_member_order = "bysource"
autodoc_typehints = "none"
autodoc_default_options = {"members": True, "show-inheritance": True}
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_ivar = True  # a dataclass's fields and its "Attributes:" are not duplicated
napoleon_use_rtype = False
autodoc_preserve_defaults = True  # show ``t=TIMES``, not the 100 values
add_module_names = False

# -- Markdown pages (docs/*.md) -------------------------------------------------------
myst_heading_anchors = 3

# -- Tutorials: runnable scripts in examples/gallery/plot_*.py ---------------------------
sphinx_gallery_conf = {
    "examples_dirs": ["../examples/gallery"],
    "gallery_dirs": ["auto_examples"],
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"__init__\.py",
    "backreferences_dir": "gen_modules/backreferences",
    "doc_module": ("nh_operators",),
    "image_scrapers": ("gallery_scrapers.figure_scraper", "matplotlib"),
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "min_reported_time": 1,
    "capture_repr": (),  # show what a script prints, not the repr of its last value
    "show_memory": False,
    "abort_on_example_error": True,
}

# -- HTML -------------------------------------------------------------------------------
html_theme = "furo"
html_title = f"nh-operators {release}"
html_static_path = []


# -- Constants re-exported by the package --------------------------------------------
# autodoc reads a constant's documentation from a ``#:`` comment next to its assignment,
# but only in the module it is documented under; ``nh_operators.TIMES`` is assigned in
# ``nh_operators._constants``. Without this hook autodoc would show the docstring of the
# value's type (ndarray, dict) instead.
def _source_comment(name, obj):
    from sphinx.pycode import ModuleAnalyzer

    attr = name.rsplit(".", 1)[-1]
    modules = sorted(m for m in sys.modules if m == "nh_operators" or m.startswith("nh_operators."))
    for modname in modules:
        if getattr(sys.modules[modname], attr, None) is not obj:
            continue
        try:
            comments = ModuleAnalyzer.for_module(modname).find_attr_docs()
        except Exception:  # noqa: BLE001 - a compiled or source-less module has none
            continue
        if ("", attr) in comments:
            return list(comments[("", attr)])
    return None


def _document_constants(app, what, name, obj, options, lines):
    if what != "data" or not name.startswith("nh_operators."):
        return
    comment = _source_comment(name, obj)
    if comment is None:
        from sphinx.util import logging

        logging.getLogger(__name__).warning(
            "%s has no '#:' comment where it is assigned; document it there", name)
        comment = []
    lines[:] = comment


# -- "Attributes:" entries that name several attributes at once ----------------------
# Docstrings here write ``q, p: (N, 100) exact trajectory``, which napoleon reads in an
# Args section but garbles in an Attributes section (it takes "q," for a type). Give
# each name its own copy of the entry before napoleon sees it.
_SHARED = re.compile(r"^(\s*)(\w+(?:,\s*\w+)+):(\s.*|)$")


def _split_shared_attributes(app, what, name, obj, options, lines):
    out, section, entry_indent, i = [], None, None, 0
    while i < len(lines):
        line = lines[i]
        indent = len(line) - len(line.lstrip())
        if line.strip() == "Attributes:":
            section, entry_indent = indent, None
        elif section is not None and line.strip() and indent <= section:
            section = None
        elif section is not None and line.strip():
            entry_indent = indent if entry_indent is None else entry_indent
            match = _SHARED.match(line)
            if indent == entry_indent and match:
                j = i + 1
                while j < len(lines) and (not lines[j].strip()
                                          or len(lines[j]) - len(lines[j].lstrip()) > indent):
                    j += 1
                body = lines[i + 1:j]
                for attr in (a.strip() for a in match.group(2).split(",")):
                    out += [f"{match.group(1)}{attr}:{match.group(3)}", *body]
                i = j
                continue
        out.append(line)
        i += 1
    lines[:] = out


def setup(app):
    app.connect("autodoc-process-docstring", _split_shared_attributes, priority=400)
    app.connect("autodoc-process-docstring", _document_constants)
