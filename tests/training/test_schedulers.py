"""HyperbolicLR / ExpHyperbolicLR against hand-computed values of the paper's formulas."""

import math

import pytest
import torch

from nh_operators import ExpHyperbolicLR, HyperbolicLR

# lr0 = 1e-2, infimum 1e-4, N = 5, U = 10: h(0) = sqrt(0.75), h(1) = sqrt(0.56),
# h(2.5) = sqrt(0.3125), h(5) = 0, worked out by hand.
HAND = {
    HyperbolicLR: {1: 8.834830128e-3, 2.5: 6.960616747e-3, 5: 1.426348503e-3},
    ExpHyperbolicLR: {1: 5.815835943e-3, 2.5: 2.432109820e-3, 5: 1.853314794e-4},
}


def _opt(lr=1e-2):
    return torch.optim.AdamW([torch.nn.Parameter(torch.zeros(2))], lr=lr)


def _lr(opt):
    return opt.param_groups[0]["lr"]


@pytest.mark.parametrize("cls", [HyperbolicLR, ExpHyperbolicLR])
def test_per_epoch_values_match_hand_computation(cls):
    opt = _opt()
    sched = cls(opt, upper_bound=10, max_iter=5, infimum_lr=1e-4)
    seen = {0: _lr(opt)}
    for epoch in range(1, 6):
        opt.step()
        sched.step()
        seen[epoch] = _lr(opt)
    assert seen[0] == 1e-2
    for epoch in (1, 5):
        assert seen[epoch] == pytest.approx(HAND[cls][epoch], rel=1e-9)


@pytest.mark.parametrize("cls", [HyperbolicLR, ExpHyperbolicLR])
def test_per_iteration_follows_fractional_epochs(cls):
    opt = _opt()
    sched = cls(opt, upper_bound=10, max_iter=5, infimum_lr=1e-4, steps_per_epoch=4)
    for _ in range(10):  # 10 iterations = 2.5 epochs
        opt.step()
        sched.step()
    assert _lr(opt) == pytest.approx(HAND[cls][2.5], rel=1e-9)
    for _ in range(10):
        opt.step()
        sched.step()
    assert _lr(opt) == pytest.approx(HAND[cls][5], rel=1e-9)


@pytest.mark.parametrize("cls", [HyperbolicLR, ExpHyperbolicLR])
def test_per_epoch_stepping_in_an_iteration_loop_holds_the_rate_within_an_epoch(cls):
    opt = _opt()
    sched = cls(opt, upper_bound=10, max_iter=5, infimum_lr=1e-4, steps_per_epoch=4,
                per_epoch=True)
    seen = []
    for _ in range(20):
        seen.append(_lr(opt))
        opt.step()
        sched.step()
    assert seen[:4] == [1e-2] * 4
    assert seen[4:8] == [pytest.approx(HAND[cls][1], rel=1e-9)] * 4
    assert _lr(opt) == pytest.approx(HAND[cls][5], rel=1e-9)
    # at 2.5 epochs (iteration 10) it still holds epoch 2's value, not h(2.5)'s
    assert seen[10] == seen[8] != pytest.approx(HAND[cls][2.5], rel=1e-3)


@pytest.mark.parametrize("cls", [HyperbolicLR, ExpHyperbolicLR])
def test_reaches_infimum_when_upper_bound_equals_epochs_and_then_holds(cls):
    opt = _opt()
    sched = cls(opt, upper_bound=7, max_iter=7, infimum_lr=1e-5)
    for _ in range(9):
        opt.step()
        sched.step()
    assert _lr(opt) == pytest.approx(1e-5, rel=1e-12)


def test_exp_schedule_with_n_equal_u_is_the_papers_asymptote():
    # h(x) = (U − x)/U when N = U, so log η = log η0 − (log η0 − log η_inf) x / U
    opt = _opt(1e-3)
    sched = ExpHyperbolicLR(opt, upper_bound=400, max_iter=400, infimum_lr=1e-6)
    for x in range(1, 301):
        opt.step()
        sched.step()
        if x % 50 == 0:
            expected = math.log(1e-3) - (math.log(1e-3) - math.log(1e-6)) * x / 400
            assert math.log(_lr(opt)) == pytest.approx(expected, rel=1e-12)


def test_state_dict_round_trip():
    opt = _opt()
    sched = ExpHyperbolicLR(opt, 10, 5, 1e-4, steps_per_epoch=3)
    for _ in range(4):
        opt.step()
        sched.step()
    opt2 = _opt()
    sched2 = ExpHyperbolicLR(opt2, 10, 5, 1e-4, steps_per_epoch=3)
    sched2.load_state_dict(sched.state_dict())
    opt2.load_state_dict(opt.state_dict())
    opt.step(), sched.step(), opt2.step(), sched2.step()
    assert _lr(opt2) == _lr(opt)


@pytest.mark.parametrize("kwargs, match", [
    (dict(upper_bound=4, max_iter=5, infimum_lr=1e-4), "upper_bound"),
    (dict(upper_bound=10, max_iter=5, infimum_lr=1e-2), "infimum_lr"),
    (dict(upper_bound=10, max_iter=0, infimum_lr=1e-4), "max_iter"),
    (dict(upper_bound=10, max_iter=5, infimum_lr=1e-4, steps_per_epoch=0),
     "steps_per_epoch"),
])
def test_bad_arguments_are_named(kwargs, match):
    with pytest.raises(ValueError, match=match):
        HyperbolicLR(_opt(), **kwargs)


def test_adjusted_infimum_matches_hand_computation():
    from nh_operators.training import adjusted_infimum_lr

    # MambONet's tuned values (paper, TPE table): eta0 = 9.7931e-4, eta_inf = 1.0310e-5,
    # U = 350. By hand, N = 250: h(0) = sqrt(250/350 (2 - 250/350)) = 0.958315;
    # log eta_N(N) - log eta0 = -0.958315 * ln(94.9864) = -4.363911;
    # log of the result = (ln 9.7931e-4 + ln 1.0310e-5 + 1.4 * -4.363911) / 2 = -12.260267
    assert adjusted_infimum_lr(9.7931e-4, 1.0310e-5, 350, 250) == pytest.approx(
        math.exp(-12.260267), rel=1e-6)
    assert adjusted_infimum_lr(9.7931e-4, 1.0310e-5, 350, 250) == pytest.approx(4.73624e-6,
                                                                              rel=1e-5)
    # N = 50: h(0) = 0.515079, 7 * (-0.515079 * 4.553734) = -16.418721, so
    # (-6.928628 - 11.482388 - 16.418721) / 2 = -17.414890
    assert adjusted_infimum_lr(9.7931e-4, 1.0310e-5, 350, 50) == pytest.approx(
        math.exp(-17.414890), rel=1e-5)
    # with N = U the schedule ends on its asymptote: nothing to adjust
    assert adjusted_infimum_lr(1e-3, 1e-5, 300, 300) == pytest.approx(1e-5, rel=1e-12)
    with pytest.raises(ValueError, match="1 ≤ epochs ≤ upper_bound"):
        adjusted_infimum_lr(1e-3, 1e-5, 200, 250)
    with pytest.raises(ValueError, match="must be positive"):
        adjusted_infimum_lr(0.0, 1e-5, 300, 250)
