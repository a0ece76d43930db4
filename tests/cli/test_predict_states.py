"""predict --q0 --p0 and far times: the table, the orbit figure, the refusals (issue 14)."""

import math
import re

import numpy as np

from nh_operators.cli.main import main


def test_predict_from_a_state_at_far_times_draws_the_orbit(tmp_path, capsys):
    fig = tmp_path / "fig.png"
    assert main(["predict", "--potential", "8*(q-0.5)**2", "--q0", "0.3", "--p0", "0.5",
                 "--times", "0.5", "100", "1e6", "--out", str(fig)]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if re.match(r"\s*\d+\.\d{4} ", line)]
    t = np.array([float(r[0]) for r in rows])
    A, phi = math.hypot(0.3 - 0.5, 0.5 / 4), math.atan2(-0.5 / 4, 0.3 - 0.5)
    np.testing.assert_allclose([float(r[1]) for r in rows], 0.5 + A * np.cos(4 * t + phi),
                               atol=1e-6)
    orbit = tmp_path / "fig_orbit.png"
    assert f"figure: {orbit}" in out and orbit.read_bytes()[:4] == b"\x89PNG"


def test_predict_refuses_huge_times_and_bad_states(capsys):
    assert main(["predict", "--potential", "8*(q-0.5)**2", "--times", "1e300"]) == 2
    assert "t = 1e+300 is beyond what float64 resolves" in capsys.readouterr().err
    assert main(["predict", "--potential", "sho", "--q0", "0.5", "--p0", "3"]) == 2
    assert "has energy p0²/2 + V(q0) = 4.5 > V0 = 2" in capsys.readouterr().err
