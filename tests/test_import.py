import os
import subprocess
import sys

import pytest


def _run(code, tmp_path, **env):
    base = {k: v for k, v in os.environ.items() if k not in ("DDE_BACKEND", "DDEBACKEND")}
    base.update(HOME=str(tmp_path), **env)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=base)


def test_import_selects_pytorch_quietly_and_writes_nothing_at_home(tmp_path):
    # the package selects the backend; deepxde is loaded (quietly) by the first name that
    # needs it, here BoundedPotentialSpace, a DeepXDE function space
    res = _run("import nh_operators; nh_operators.BoundedPotentialSpace; import deepxde; "
               "print(deepxde.backend.backend_name)", tmp_path)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "pytorch"
    assert res.stderr == ""
    # deepxde would otherwise write ~/.deepxde/config.json; matplotlib (imported by
    # deepxde) keeps its usual font cache under ~/.cache, which is not ours to move.
    assert not (tmp_path / ".deepxde").exists()
    written = {p.name for p in tmp_path.iterdir()}
    assert written <= {".cache", ".config"}, written


def test_other_backend_in_environment_is_a_clear_error(tmp_path):
    res = _run("import nh_operators", tmp_path, DDE_BACKEND="jax")
    assert res.returncode != 0
    assert "DDE_BACKEND='jax'" in res.stderr and "needs 'pytorch'" in res.stderr


def test_deepxde_already_imported_with_other_backend_is_a_clear_error(tmp_path):
    code = (
        "import sys, types\n"
        "fake = types.ModuleType('deepxde'); fake.backend = types.SimpleNamespace(backend_name='paddle')\n"
        "sys.modules['deepxde'] = fake\n"
        "import nh_operators\n"
    )
    res = _run(code, tmp_path)
    assert res.returncode != 0
    assert "already imported with the 'paddle' backend" in res.stderr


def test_public_names_are_exported():
    import nh_operators

    for name in nh_operators.__all__:
        assert hasattr(nh_operators, name), name


_HEAVY = ("torch", "deepxde", "numba", "matplotlib", "h5py")


def test_import_loads_no_heavy_library(tmp_path):
    res = _run("import sys, nh_operators; print(sorted(m for m in " + repr(_HEAVY)
               + " if m in sys.modules))", tmp_path)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "[]"


def test_a_classical_solve_never_loads_torch_or_deepxde(tmp_path):
    code = ("import sys, nh_operators as nh\n"
            "s = nh.solve('8*(q-0.5)**2', [0.5, 1.5], tol=1e-8)\n"
            "s2 = nh.solve(nh.PHYSICAL_POTENTIALS['sho'].V(nh.SENSORS), [0.5], tol=1e-6)\n"
            "print(s.kind, s2.kind, [m for m in ('torch', 'deepxde', 'scipy.interpolate',\n"
            "                                    'scipy.integrate') if m in sys.modules])")
    res = _run(code, tmp_path)
    assert res.returncode == 0, res.stderr
    # scipy.interpolate and scipy.integrate cost 0.5-1 s of a first answer's ~1.5 s; only
    # B-spline conversion, PCHIP, the reference solver and a network's estimate need them
    assert res.stdout.strip() == "classical classical []"


def test_help_and_argument_errors_load_no_heavy_library(tmp_path):
    code = ("import sys\nfrom nh_operators.cli import main\n"
            "codes = [main(['--help']), main(['generate', '--chunk', '0'])]\n"
            "print(codes, sorted(m for m in " + repr(_HEAVY) + " if m in sys.modules))")
    res = _run(code, tmp_path)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip().splitlines()[-1] == "[0, 2] []"


def test_lazy_names_are_the_wings_objects_and_listed():
    import nh_operators
    from nh_operators import solvers

    assert nh_operators.integrate is solvers.integrate
    assert "solve_many" in dir(nh_operators) and "integrate" in dir(solvers)
    with pytest.raises(AttributeError, match="has no attribute 'nope'"):
        nh_operators.nope


def test_a_classical_predict_loads_no_torch(tmp_path):
    """``nh-operators predict`` with a formula answers classically: its method tables
    imported the network wrapper (and torch, about 3.5 s of a 6 s process) at module
    level; now only a neural method imports it."""
    code = ("import sys\nfrom nh_operators.cli import main\n"
            "main(['predict', '--potential', '8*(q-0.5)**2', '--times', '0.5', '--tol', "
            "'1e-6'])\nprint(sorted(m for m in ('torch', 'deepxde') if m in sys.modules))")
    res = _run(code, tmp_path)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip().splitlines()[-1] == "[]"


def test_top_level_exposes_no_private_name():
    import nh_operators as nh

    assert [n for n in nh.__all__ if n.startswith("_") and not n.startswith("__")] == []
    # helpers used while importing are not left on the package
    for name in ("_ensure_pytorch_backend", "_select_pytorch_backend", "select_pytorch_backend",
                 "attach", "_names"):
        assert not hasattr(nh, name), name


def test_optional_dependency_error_names_the_extra(monkeypatch):
    from nh_operators import _extras

    def missing(name):
        err = ModuleNotFoundError(f"No module named {name!r}")
        err.name = name
        raise err

    monkeypatch.setattr(_extras.importlib, "import_module", missing)
    with pytest.raises(ImportError, match=r"pip install 'nh-operators\[fno\]'"):
        _extras.require("neuralop.models")
    with pytest.raises(ImportError, match=r"nh-operators\[tune\]"):
        _extras.require("optuna")
    with pytest.raises(ValueError, match="not an optional dependency"):
        _extras.require("numpy")
