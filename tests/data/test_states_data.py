"""Datasets with starting states: the energy-stratified draw, exact labels from each
state, and the same bytes whatever the chunk size."""

import numpy as np
import pytest

from nh_operators import V0, BoundedPotentialSpace
from nh_operators.data import generate_dataset, load_dataset
from nh_operators.potentials import PHYSICAL_POTENTIALS
from nh_operators.solvers import STATE_UNIFORMS, energy_states, reference_solve
from nh_operators.solvers.rows import row_source


def test_energy_is_uniform_and_separatrix_draws_sit_at_the_barrier():
    dw = PHYSICAL_POTENTIALS["double_well"]  # one interior maximum
    values = lambda x: dw.V(x)  # noqa: E731
    u = np.random.default_rng(3).random((4000, STATE_UNIFORMS))
    q0, p0, near = energy_states(values, u, separatrix_share=0.25)
    energy = 0.5 * p0**2 + dw.V(q0)
    assert np.all(energy <= V0 + 1e-12) and np.all((q0 >= 0) & (q0 <= 1))
    assert abs(near.mean() - 0.25) < 0.03  # the share asked, up to sampling noise
    x = np.linspace(0, 1, 200_001)
    v = dw.V(x)
    inner = (x > 0.2) & (x < 0.8)
    barrier, v_min = v[inner].max(), v.min()
    # near draws: within 1e-4..1e-1 of the energy range of the barrier, on either side
    gap = np.abs(energy[near] - barrier) / (V0 - v_min)
    assert gap.min() >= 0.9e-4 and gap.max() <= 0.1 + 1e-6
    assert 0.3 < np.mean(energy[near] > barrier) < 0.7
    # the others: uniform in [V_min, V0] (Kolmogorov–Smirnov distance)
    level = np.sort((energy[~near] - v_min) / (V0 - v_min))
    ks = np.max(np.abs(level - np.arange(1, level.size + 1) / level.size))
    assert ks < 1.63 / np.sqrt(level.size)  # 1 % level


def test_energy_states_refuse_bad_arguments():
    with pytest.raises(ValueError, match=r"uniforms must have shape \(N, 5\)"):
        energy_states(lambda x: x, np.zeros((3, 4)))
    with pytest.raises(ValueError, match="separatrix_share must be in"):
        energy_states(lambda x: x, np.zeros((3, 5)), separatrix_share=1.5)


def test_a_dataset_with_states_is_exact_and_independent_of_the_chunk(tmp_path):
    a = generate_dataset(24, seed=5, path=tmp_path / "a.h5", chunk=7, progress=False,
                         states="energy", separatrix_share=0.5)
    b = generate_dataset(24, seed=5, path=tmp_path / "b.h5", chunk=24, progress=False,
                         states="energy", separatrix_share=0.5)
    for name in ("V", "q", "p", "q0", "p0", "near_separatrix"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.checksum == b.checksum
    assert a.attrs["states"]["separatrix_share"] == 0.5
    # the potentials are those of a dataset without states (same generator stream)
    plain = generate_dataset(24, seed=5, progress=False)
    np.testing.assert_array_equal(plain.V, a.V)
    # labels start at the stored state and match an independent solve from it
    pots = a.potentials()
    np.testing.assert_allclose(a.q[:, 0], a.q0, rtol=0, atol=1e-13)
    q, p = reference_solve(pots, a.t, q0=a.q0, p0=a.p0)
    np.testing.assert_array_equal(q, a.q)
    energy = 0.5 * a.p0**2 + row_source(pots, "exact V").values_at(a.q0[:, None])[:, 0]
    assert np.all(energy <= V0 + 1e-12)
    assert not np.all(a.q0 == 0)
    # the network input: sensors, then q0 and p0
    data = load_dataset(tmp_path / "a.h5").to_deepxde()
    assert data.train_x[0].shape == (19, 102)
    full = a.branch_input()
    np.testing.assert_array_equal(full[:, 100], a.q0)
    np.testing.assert_array_equal(full[:, 101], a.p0)


def test_states_must_be_named():
    with pytest.raises(ValueError, match="states must be None or 'energy'"):
        generate_dataset(4, seed=0, progress=False, states="uniform")


def test_energy_states_on_generator_potentials_cover_the_energies():
    space = BoundedPotentialSpace(seed=9)
    pots = space.potentials(space.random(300))
    u = np.random.default_rng(1).random((300, STATE_UNIFORMS))
    q0, p0, near = energy_states(row_source(pots, "exact V").values_at, u)
    src = row_source(pots, "exact V")
    energy = 0.5 * p0**2 + src.values_at(q0[:, None])[:, 0]
    assert np.all(energy <= V0 + 1e-12)
    # every tenth of the energy range is drawn
    v_min = src.values_at(np.broadcast_to(np.linspace(0, 1, 1025), (300, 1025))).min(axis=1)
    level = (energy - v_min) / (V0 - v_min)
    assert np.all(np.histogram(level[~near], bins=10, range=(0, 1))[0] > 0)


def test_an_interrupted_states_dataset_resumes_to_the_same_bytes(tmp_path, monkeypatch):
    import nh_operators.data.generate as generate_module

    whole = generate_dataset(30, seed=6, path=tmp_path / "whole.h5", chunk=10,
                             progress=False, states="energy")
    original, calls = generate_module.SampleSource.take, {"n": 0}

    def interrupted(self, n, drops=None):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt
        return original(self, n, drops)

    monkeypatch.setattr(generate_module.SampleSource, "take", interrupted)
    with pytest.raises(KeyboardInterrupt):
        generate_dataset(30, seed=6, path=tmp_path / "cut.h5", chunk=10, progress=False,
                         states="energy")
    monkeypatch.setattr(generate_module.SampleSource, "take", original)
    resumed = generate_dataset(30, seed=6, path=tmp_path / "cut.h5", chunk=10,
                               progress=False, states="energy")
    for name in ("q0", "p0", "near_separatrix", "q", "p"):
        np.testing.assert_array_equal(getattr(resumed, name), getattr(whole, name))
    assert resumed.checksum == whole.checksum
