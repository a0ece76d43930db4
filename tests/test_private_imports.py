"""No module of the package imports a private name from another module (issue 40).

The rule: ``from .x import _name`` (or ``..x``, or the absolute form), where ``_name``
starts with an underscore and is not a module, fails. Importing a private *module*
(``from .. import _constants``, ``from ._kernels import ...`` of public names,
``import nh_operators._backend``) is fine, as is ``from .x import name as _alias``
(the private name is local to the importer). Tests may import anything.

Every module is parsed with ``ast``, the imports inside functions included.
"""

import ast
from pathlib import Path

import pytest

import nh_operators

PACKAGE = Path(nh_operators.__file__).resolve().parent


def _is_module(base: Path, name: str) -> bool:
    return (base / f"{name}.py").is_file() or (base / name / "__init__.py").is_file()


def private_imports(path: Path, root: Path = PACKAGE) -> set[str]:
    """The private names (not modules) that module ``path`` imports from another module
    of the package rooted at ``root``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            base = path.parent
            for _ in range(node.level - 1):
                base = base.parent
        elif node.module and node.module.split(".")[0] == root.name:
            base = root.parent
        else:
            continue  # another package's names are its business
        for part in (node.module or "").split("."):
            if part:
                base = base / part
        for alias in node.names:
            if alias.name.startswith("_") and not alias.name.startswith("__") \
                    and not _is_module(base, alias.name):
                found.add(alias.name)
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
    ("from . import _priv_module", set()),           # a private module is fine
    ("from ._priv_module import open_name", set()),  # its public names too
    ("from .b import name as _alias", set()),        # a private alias of a public name
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
