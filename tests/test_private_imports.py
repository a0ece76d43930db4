"""No module of the package imports a private name from another module (issue 40).

The rule: no import line of the package names a private name: ``from .x import _name``
(or ``..x``, or the absolute form) fails whether ``_name`` is a function, a constant or a
private module, and so does ``from .x import name as _alias``. Public names of a private
module (``from .._constants import TIMES``, ``from ._kernels import batch_fixed``) are
fine: the module's underscore keeps it out of the API, not out of its own wing. Tests
may import anything.

Every module is parsed with ``ast``, the imports inside functions included.
"""

import ast
from pathlib import Path

import pytest

import nh_operators

PACKAGE = Path(nh_operators.__file__).resolve().parent


def private_imports(path: Path, root: Path = PACKAGE) -> set[str]:
    """The private names (modules and aliases included) that module ``path`` imports from
    the package rooted at ``root``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        if not node.level and (node.module or "").split(".")[0] != root.name:
            continue  # another package's names are its business
        for alias in node.names:
            for name in (alias.name, alias.asname or ""):
                if name.startswith("_") and not name.startswith("__"):
                    found.add(name)
    return found


def test_no_module_imports_a_private_name_from_another():
    problems = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        names = private_imports(path)
        if names:
            problems.append(f"{rel} imports {sorted(names)}")
    assert not problems, "\n".join(problems)


def test_solving_imports_no_private_name_at_all():
    for path in sorted((PACKAGE / "solving").rglob("*.py")):
        assert private_imports(path) == set(), path


@pytest.mark.parametrize("source, expected", [
    ("from .b import _secret", {"_secret"}),
    ("from .b import public, _x as y", {"_x"}),
    ("from . import _priv_module", {"_priv_module"}),  # a private module too
    ("from ._priv_module import open_name", set()),    # its public names are fine
    ("from .b import name as _alias", {"_alias"}),     # a private alias as well
    ("def f():\n    from ..pkg.b import _late\n", {"_late"}),
    ("from numpy import _globals", set()),           # not this package's
])
def test_the_rule_catches_what_it_should(tmp_path, source, expected):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "b.py").write_text("")
    (pkg / "_priv_module.py").write_text("")
    mod = pkg / "a.py"
    mod.write_text(source)
    assert private_imports(mod, pkg) == expected
