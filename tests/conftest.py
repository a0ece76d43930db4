import pytest

from nh_operators import TIMES, BoundedPotentialSpace
from nh_operators.solvers import reference_solve


def pytest_addoption(parser):
    parser.addoption("--runslow", action="store_true", default=False, help="also run slow tests")


def pytest_collection_modifyitems(config, items):
    import torch

    no_gpu = pytest.mark.skip(reason="gpu: needs CUDA")
    skip = pytest.mark.skip(reason="slow: run with --runslow")
    for item in items:
        if "gpu" in item.keywords and not torch.cuda.is_available():
            item.add_marker(no_gpu)
        if "slow" in item.keywords and not config.getoption("--runslow"):
            item.add_marker(skip)


# ------------------------------------------ random B-spline potentials for the solvers


@pytest.fixture(scope="session")
def pots():
    """Eight generator potentials (seed 8407), batched."""
    return BoundedPotentialSpace.potentials(BoundedPotentialSpace(seed=8407).random(8))


@pytest.fixture(scope="session")
def reference(pots):
    q, p, info = reference_solve(pots, TIMES, full_output=True)
    return q, p, info
