import os
import subprocess
import sys


def _run(code, tmp_path, **env):
    base = {k: v for k, v in os.environ.items() if k not in ("DDE_BACKEND", "DDEBACKEND")}
    base.update(HOME=str(tmp_path), **env)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=base)


def test_import_selects_pytorch_quietly_and_writes_nothing_at_home(tmp_path):
    res = _run("import nh_operators, deepxde; print(deepxde.backend.backend_name)", tmp_path)
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
