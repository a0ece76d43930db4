"""The layering rule (docs/architecture.rst): each wing imports only the wings beneath it.

Every module's imports are read with ``ast`` (``nh_operators._architecture``), those inside
functions included. The rule is checked on the package, and on small packages written
here with a deliberately bad import, to show that it would catch one.
"""

import importlib
import textwrap
from pathlib import Path

import pytest

import nh_operators
from nh_operators._architecture import (
    WINGS,
    import_cycles,
    import_graph,
    layer_violations,
    wing_imports,
    wing_of,
)

PACKAGE = Path(nh_operators.__file__).resolve().parent


@pytest.fixture(scope="module")
def graph():
    return import_graph(PACKAGE)


def test_no_import_runs_upward_or_sideways(graph):
    problems = layer_violations(graph)
    assert not problems, "\n".join(problems)


def test_no_import_cycle_between_modules(graph):
    cycles = import_cycles(graph)
    assert not cycles, "\n".join(cycles)


def test_every_module_is_in_a_declared_wing_or_a_private_root_helper(graph):
    for module in graph:
        wing = wing_of(module)
        assert wing in WINGS or wing is None or module in ("nh_operators", "nh_operators.__main__"), \
            module
    assert {wing_of(m) for m in graph} - {None, ""} == set(WINGS)


def test_no_module_is_over_400_lines():
    long = {str(p.relative_to(PACKAGE)): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 400}
    assert not long, f"modules over 400 lines: {long}"


def test_graph_sees_imports_inside_functions_and_resolves_submodules(graph):
    targets = {(a.target, a.line) for a in graph["nh_operators.solving.shipped"]}
    # solving/shipped.py imports the evaluation wing inside a function
    assert any(t == "nh_operators.evaluation" for t, _ in targets)
    fixed = {a.target for a in graph["nh_operators.solvers.fixed_step"]}
    assert "nh_operators.potentials._spline_kernels" in fixed  # from ..potentials import mod
    assert "nh_operators.solvers.schemes" in fixed


def test_the_old_cycles_are_broken_at_the_right_depth(graph):
    # solvers <-> resolution: the shared schemes sit beneath both
    assert "nh_operators.solvers.fixed_step" not in {
        a.target for a in graph["nh_operators.solvers.resolution"]}
    # evaluate -> methods -> stability -> evaluate: the loss moved to a root helper
    stability = {a.target for a in graph["nh_operators.evaluation.stability"]}
    assert "nh_operators._metrics" in stability
    assert "nh_operators.evaluation.baselines" not in stability


def test_wing_counts_follow_the_levels(graph):
    for (src, dst), n in wing_imports(graph).items():
        assert n > 0
        if src != "_" and dst != "_":
            assert WINGS[dst][0] < WINGS[src][0], (src, dst)


def test_every_wing_reexports_its_public_names():
    for wing in WINGS:
        module = importlib.import_module(f"nh_operators.{wing}")
        assert module.__all__, wing
        for name in module.__all__:
            assert hasattr(module, name), f"nh_operators.{wing}.__all__ names missing {name}"


# ------------------------------------------------ the checker on deliberately bad trees


def _package(tmp_path, files):
    root = tmp_path / "pkg"
    for rel, text in {"__init__.py": "", **files}.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return root


def _check(root):
    g = import_graph(root, package="pkg")
    return layer_violations(g, package="pkg"), import_cycles(g)


def test_checker_catches_an_upward_import_and_names_the_pair(tmp_path):
    root = _package(tmp_path, {
        "potentials/__init__.py": "",
        "potentials/bounded.py": "from ..solvers.fixed_step import integrate\n",
        "solvers/__init__.py": "",
        "solvers/fixed_step.py": "def integrate():\n    pass\n",
    })
    problems, cycles = _check(root)
    assert len(problems) == 1 and not cycles
    assert "pkg.potentials.bounded imports pkg.solvers.fixed_step at line 1" in problems[0]
    assert "wing 'potentials' (level 0) may not import wing 'solvers' (level 1, above it)" \
        in problems[0]


def test_checker_catches_an_upward_import_hidden_in_a_function(tmp_path):
    root = _package(tmp_path, {
        "solvers/__init__.py": "",
        "solvers/fixed_step.py": "def f():\n    from ..evaluation import report\n",
        "evaluation/__init__.py": "",
        "evaluation/report.py": "",
    })
    problems, _ = _check(root)
    assert len(problems) == 1 and "pkg.solvers.fixed_step imports pkg.evaluation.report " \
        "at line 2" in problems[0]


def test_checker_catches_a_sideways_import_a_root_helper_and_an_unknown_folder(tmp_path):
    root = _package(tmp_path, {
        "models/__init__.py": "from ..potentials import bounded\n",
        "potentials/__init__.py": "",
        "potentials/bounded.py": "",
        "_helper.py": "import pkg.data.generate\n",
        "data/__init__.py": "",
        "data/generate.py": "from .. import solve\n",
        "misc/thing.py": "",
    })
    problems, _ = _check(root)
    text = "\n".join(problems)
    assert "wing 'models' (level 0) may not import wing 'potentials' (level 0, beside it)" in text
    assert "pkg._helper (a root helper) imports pkg.data.generate" in text
    assert "pkg.data.generate imports the package itself (pkg)" in text
    assert "pkg.misc.thing is in folder 'misc', which is not a declared wing" in text


def test_checker_catches_a_cycle_inside_a_wing_and_names_the_pair(tmp_path):
    root = _package(tmp_path, {
        "evaluation/__init__.py": "from .methods import run\n",
        "evaluation/methods.py": "from .stability import check\n\ndef run():\n    pass\n",
        "evaluation/stability.py": "def check():\n    from .evaluate import loss\n",
        "evaluation/evaluate.py": "from .methods import run\n\ndef loss():\n    pass\n",
    })
    problems, cycles = _check(root)
    assert not problems
    assert cycles == ["pkg.evaluation.evaluate <-> pkg.evaluation.methods "
                      "(pkg.evaluation.evaluate -> pkg.evaluation.methods -> "
                      "pkg.evaluation.stability -> pkg.evaluation.evaluate)"]


def test_checker_catches_a_module_importing_its_own_wing_init(tmp_path):
    root = _package(tmp_path, {
        "solvers/__init__.py": "from .fixed_step import integrate\n",
        "solvers/fixed_step.py": "from . import schemes\nfrom ..solvers import ORDERS\n",
        "solvers/schemes.py": "ORDERS = {}\n",
    })
    _, cycles = _check(root)
    assert cycles == ["pkg.solvers <-> pkg.solvers.fixed_step "
                      "(pkg.solvers -> pkg.solvers.fixed_step -> pkg.solvers)"]


def test_a_good_tree_passes(tmp_path):
    root = _package(tmp_path, {
        "potentials/__init__.py": "from .bounded import B\n",
        "potentials/bounded.py": "from .._constants import V0\nB = V0\n",
        "_constants.py": "V0 = 2.0\n",
        "solvers/__init__.py": "from .fixed_step import f\n",
        "solvers/fixed_step.py": "from ..potentials import B\n\ndef f():\n"
                                 "    from . import schemes\n",
        "solvers/schemes.py": "",
    })
    assert _check(root) == ([], [])
