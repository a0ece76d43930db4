"""The documentation site covers the public API (parsed from the .rst sources; no Sphinx build)."""

import importlib
import re
from pathlib import Path

import pytest

import nh_operators
from nh_operators._architecture import WINGS

DOCS = Path(__file__).resolve().parent.parent / "docs"
GALLERY = DOCS.parent / "examples" / "gallery"

_DIRECTIVE = re.compile(r"^(\s*)\.\.\s+([\w:-]+)::\s*(.*?)\s*$")
_AUTODOC = {"autofunction", "autoclass", "autodata", "autoexception", "automethod",
            "autoattribute", "automodule", "py:function", "py:class", "py:data",
            "py:exception"}


def documented_names(text):
    """Fully qualified names an .rst text documents with autosummary or autodoc.

    Follows ``.. currentmodule::`` (``.. module::``) as Sphinx does: a name in an
    autosummary block or an ``auto*`` directive is taken relative to the current module
    unless it is already qualified with it.
    """
    names, module = set(), None
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        match = _DIRECTIVE.match(lines[i])
        i += 1
        if not match:
            continue
        indent, directive, argument = match.groups()
        if directive in ("currentmodule", "module", "py:currentmodule", "py:module"):
            module = None if argument == "None" else argument
        elif directive in _AUTODOC and argument:
            names.add(_qualify(argument.split("(")[0], module))
        elif directive == "autosummary":
            # The block: lines indented deeper than the directive; options start with ':'.
            while i < len(lines) and (not lines[i].strip()
                                      or len(lines[i]) - len(lines[i].lstrip()) > len(indent)):
                entry = lines[i].strip()
                i += 1
                if entry and not entry.startswith(":") and not entry.startswith(".."):
                    names.add(_qualify(entry.split()[0], module))
    return names


def _qualify(name, module):
    name = name.lstrip("~!")
    if module is None or name == module or name.startswith(module + "."):
        return name
    return f"{module}.{name}"


def api_names():
    return set().union(*(documented_names(p.read_text(encoding="utf-8"))
                         for p in sorted(DOCS.glob("*.rst"))))


def test_parser_follows_currentmodule_and_autosummary_blocks():
    text = """
.. currentmodule:: pkg

.. autosummary::
   :toctree: generated
   :nosignatures:

   solve
   ~pkg.TIMES

Text.

   not_a_name_outside_the_block

.. currentmodule:: pkg.sub

.. autofunction:: helper
.. autoclass:: pkg.sub.Thing
"""
    assert documented_names(text) == {"pkg.solve", "pkg.TIMES", "pkg.sub.helper",
                                      "pkg.sub.Thing"}


def _wings():
    return [w for w in WINGS if w != "cli"]


def test_every_public_name_has_an_api_page():
    """Each name of nh.__all__ is documented at the top or under the wing that exports it."""
    documented = api_names()
    missing = []
    for n in nh_operators.__all__:
        obj = getattr(nh_operators, n)
        homes = [f"nh_operators.{n}"] + [
            f"nh_operators.{w}.{n}" for w in _wings()
            if getattr(importlib.import_module(f"nh_operators.{w}"), n, None) is obj]
        if not documented.intersection(homes):
            missing.append(n)
    assert not missing, (f"names in nh_operators.__all__ missing from the API reference "
                         f"(docs/api.rst): {missing}")


@pytest.mark.parametrize("wing", [w for w in WINGS if w != "cli"])
def test_every_name_a_wing_exports_has_an_api_page(wing):
    documented = api_names()
    module = importlib.import_module(f"nh_operators.{wing}")
    missing = sorted(n for n in module.__all__ if f"nh_operators.{wing}.{n}" not in documented)
    assert not missing, f"nh_operators.{wing}.__all__ names missing from docs/api.rst: {missing}"


def test_api_pages_name_only_objects_that_exist():
    for name in sorted(api_names()):
        parts = name.split(".")
        obj = __import__(parts[0])
        for k, part in enumerate(parts[1:], start=1):
            if not hasattr(obj, part):  # a submodule not imported by the package
                obj = __import__(".".join(parts[:k + 1]), fromlist=["_"])
            else:
                obj = getattr(obj, part)
        assert obj is not None, name


@pytest.mark.parametrize("page", ["install", "quickstart", "usage", "measurements",
                                  "problem", "distributions",
                                  "architectures", "architecture",
                                  "training", "training_at_scale", "speed_accuracy", "extending", "api",
                                  "numerics", "models", "evaluation", "solve", "pretrained",
                                  "auto_examples/index"])
def test_index_toctree_lists_every_page(page):
    index = (DOCS / "index.rst").read_text(encoding="utf-8")
    assert re.search(rf"^\s+{re.escape(page)}\s*$", index, re.MULTILINE), page


def test_gallery_scripts_have_a_title_and_the_plot_prefix():
    scripts = sorted(GALLERY.glob("*.py"))
    assert scripts, "no tutorial scripts in examples/gallery"
    for script in scripts:
        assert script.name.startswith("plot_"), f"{script.name}: sphinx-gallery runs plot_*.py"
        head = script.read_text(encoding="utf-8").lstrip()
        assert head.startswith('"""'), f"{script.name}: needs a docstring with a title"
        title, underline = head[3:].strip().splitlines()[:2]
        assert set(underline) == {"="} and len(underline) >= len(title), script.name


README = DOCS.parent / "README.md"


def _readme_sections():
    """The README's ``## `` sections: {title: body}, in order."""
    sections, title = {}, None
    for line in README.read_text(encoding="utf-8").splitlines():
        if line.startswith("## "):
            title = line[3:].strip()
            sections[title] = []
        elif title is not None:
            sections[title].append(line)
    return {k: "\n".join(v) for k, v in sections.items()}


def test_readme_leads_within_150_lines():
    """What a newcomer needs comes first; the rest is in the docs (issue 42)."""
    lines = README.read_text(encoding="utf-8").splitlines()
    before_links = lines[:next(i for i, line in enumerate(lines)
                               if line.startswith("## Where to read on"))]
    assert len(before_links) <= 150, len(before_links)
    assert list(_readme_sections())[:5] == ["Set up", "Quick start", "Which method for which job",
                                            "Headline results", "What it cannot do yet"]
    setup = _readme_sections()["Set up"]
    assert "make demo" in setup and "make test" in setup and "minute" in setup
    assert "numba" in _readme_sections()["Quick start"]  # the compile stall of a new formula
    jobs = _readme_sections()["Which method for which job"]
    for call in ("nh.solve(", "nh.solve_many(", "nh.build_model(", "torchrun",
                 "--preset paper-standard", "docs/any_problem.md"):
        assert call in jobs, call


def test_readme_headline_figures_each_state_their_command():
    for bullet in _readme_sections()["Headline results"].split("\n- ")[1:]:
        assert re.search(r"`(python benchmarks/|nh-operators )", bullet), bullet[:80]


def test_readme_and_moved_pages_carry_no_dated_remarks():
    for path in (README, DOCS / "usage.md", DOCS / "measurements.md"):
        text = path.read_text(encoding="utf-8")
        for pattern in (r"20\d\d-\d\d-\d\d", r"previous session", r"faster machine",
                        r"busier machine", r"minutes apart"):
            assert not re.search(pattern, text), (path.name, pattern)
