"""Do torch's intra-op threads pay for a network's CPU forward at batch 1,000? (issue 41)

This is what ``PhaseONet.cpu_torch_threads`` and its threshold ``LIGHT_TORCH_MACS``
(``nh_operators/models/phaseonet.py``) rest on. On ``--rows`` fresh Algorithm-1
potentials, at the 100 times of :data:`~nh_operators.TIMES`, without a graph, it prints
µs per trajectory, medians of ``--repeats`` rounds (round robin,
:func:`api_overhead.round_robin`).

* **Forwards** of networks at three thread settings, torch / numba: 1/1, 2/2 and 1/2.
  The networks are PhaseONets of three sizes (randomly initialised: timing only) and
  the shipped ``phaseonet-alg1-states``, ``fno-alg1`` and ``deeponet-alg1``. The
  PhaseONet forward is called directly, so ``cpu_torch_threads`` does not apply.
* **Pieces** of ``phaseonet-paper-quadrature``'s forward at 1/1 and 2/2: the period's
  float64 product, the compiled inversion, the MLP, the basis product and the
  compiled read-out.
* **Rows split over Python threads** (``--split``): the quadrature network's batch in
  two halves, each run whole on its own thread with torch and numba serial, beside the
  halves one after the other and the whole batch at torch 1 / numba 2.

Run it with::

    OMP_WAIT_POLICY=PASSIVE python benchmarks/cost/torch_threads.py [--rows 1000] \\
        [--repeats 31] [--split]
"""

from __future__ import annotations

import argparse
import concurrent.futures
import os
import sys

import numba
import numpy as np
import torch

import nh_operators as nh
from nh_operators.models.phase_rules import rest_tables
from nh_operators.models.phaseonet import PhaseONet

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from api_overhead import round_robin  # noqa: E402  (a sibling script)

SETTINGS = ((1, 1), (2, 2), (1, 2))


def macs(net: PhaseONet) -> int:
    """Torch multiply-adds per row, as ``cpu_torch_threads`` counts them."""
    return sum(p.numel() for p in net.branch.parameters()) + net.basis.numel()


def networks() -> dict[str, torch.nn.Module]:
    torch.manual_seed(0)
    sizes = {"width 16, depth 1, basis 4, grid 128": {"width": 16, "depth": 1, "basis": 4,
                                                      "grid": 128},
             "width 128, depth 2, basis 32, grid 256": {},
             "width 256, depth 3, basis 32, grid 256": {"width": 256, "depth": 3}}
    nets: dict[str, torch.nn.Module] = {}
    for label, size in sizes.items():
        net = PhaseONet(shape="quadrature", **size)
        nets[f"PhaseONet {label} ({macs(net):,} MACs)"] = net
    for name in ("phaseonet-alg1-states", "fno-alg1", "deeponet-alg1"):
        nets[name] = nh.pretrained(name).net
    return nets


def forwards(V: np.ndarray, repeats: int) -> None:
    print("| network | torch 1 / numba 1 | 2 / 2 | 1 / 2 |")
    print("|---|---:|---:|---:|")
    t64 = nh.TIMES[:, None].copy()  # writable: torch warns on a read-only array
    for label, net in networks().items():
        net.eval()
        dtype = next(net.parameters()).dtype
        rows = V
        if getattr(net, "initial_state", False):  # a state on each row: (0.3, 0)
            rows = np.column_stack([V, np.full(len(V), 0.3), np.zeros(len(V))])
        x = torch.as_tensor(rows, dtype=dtype)
        t = torch.as_tensor(t64, dtype=dtype)
        cells = []
        for torch_n, numba_n in SETTINGS:
            torch.set_num_threads(torch_n)
            numba.set_num_threads(numba_n)
            with torch.no_grad():
                sec = round_robin({"f": lambda net=net, x=x, t=t: net((x, t))}, repeats)["f"]
            cells.append(f"{1e6 * sec / len(V):.2f}")
        print(f"| {label} | {' | '.join(cells)} |", flush=True)


def pieces(V: np.ndarray, repeats: int) -> None:
    net = nh.pretrained("phaseonet-paper-quadrature").net.eval()
    dtype = next(net.parameters()).dtype
    np_dtype = torch.empty(0, dtype=dtype).numpy().dtype
    x = torch.as_tensor(V, dtype=dtype)
    t = torch.as_tensor(nh.TIMES[:, None], dtype=dtype)
    rule = net.quadrature
    with torch.no_grad():
        T, start = net.start.at_rest(rule, x, net.grid, net.start_tables())
        inputs = torch.cat([(2 - x) / 2, torch.log(T).to(dtype)[:, None]], dim=1)
        coeffs = net.branch(inputs)
        tables = net.shape_tables(coeffs, start)
        f = rule.jacobian * torch.rsqrt_(rule._squared_speed(x))
        T64 = 2 * (f @ rule.weights)
        fns = {
            "the period's float64 product": lambda: rule._squared_speed(x),
            "the inversion (compiled)": lambda: rest_tables(
                f.numpy(), rule.nodes.numpy(), rule.weights.numpy(), T64.numpy(),
                rule.edges, net.grid, np_dtype),
            "the MLP": lambda: net.branch(inputs),
            "the basis product": lambda: net.shape_tables(coeffs, start),
            "the read-out (compiled)": lambda: net.read_orbit(tables, torch.reciprocal(T), t),
            "the whole forward": lambda: net((x, t)),
        }
        print("| piece of phaseonet-paper-quadrature | torch 1 / numba 1 | 2 / 2 |")
        print("|---|---:|---:|")
        cells = {name: [] for name in fns}
        for torch_n, numba_n in SETTINGS[:2]:
            torch.set_num_threads(torch_n)
            numba.set_num_threads(numba_n)
            for name, sec in round_robin(fns, repeats).items():
                cells[name].append(f"{1e6 * sec / len(V):.2f}")
    for name, row in cells.items():
        print(f"| {name} | {' | '.join(row)} |")


def _serial(net: torch.nn.Module, x: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    numba.set_num_threads(1)  # this thread's count (numba's is per thread)
    with torch.no_grad():
        return net((x, t))


def split(V: np.ndarray, repeats: int) -> None:
    net = nh.pretrained("phaseonet-alg1-quadrature").net.eval()
    dtype = next(net.parameters()).dtype
    x = torch.as_tensor(V, dtype=dtype)
    t = torch.as_tensor(nh.TIMES[:, None], dtype=dtype)
    half = len(V) // 2
    a, b = x[:half].clone(), x[half:].clone()
    torch.set_num_threads(1)
    numba.set_num_threads(2)
    pool = concurrent.futures.ThreadPoolExecutor(1)

    def both_halves_at_once():
        other = pool.submit(_serial, net, b, t)
        numba.set_num_threads(1)
        with torch.no_grad():
            net((a, t))
        numba.set_num_threads(2)
        other.result()

    def halves_in_turn():
        numba.set_num_threads(1)
        with torch.no_grad():
            net((a, t))
            net((b, t))
        numba.set_num_threads(2)

    def whole():
        with torch.no_grad():
            net((x, t))

    result = round_robin({"two halves on two threads": both_halves_at_once,
                          "two halves in turn, one thread": halves_in_turn,
                          "the whole batch, torch 1 / numba 2": whole}, repeats)
    print("| phaseonet-alg1-quadrature, rows split | µs per trajectory |")
    print("|---|---:|")
    for name, sec in result.items():
        print(f"| {name} | {1e6 * sec / len(V):.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--rows", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=31)
    parser.add_argument("--split", action="store_true",
                        help="also time the batch split by rows over Python threads")
    args = parser.parse_args()
    space = nh.BoundedPotentialSpace(seed=7)
    V = space.potentials(space.random(args.rows)).V(nh.SENSORS)
    print(f"{args.rows} Algorithm-1 potentials (seed 7), batch {args.rows}, "
          f"{args.repeats} rounds; µs per trajectory\n")
    forwards(V, args.repeats)
    print()
    pieces(V, args.repeats)
    if args.split:
        print()
        split(V, args.repeats)


if __name__ == "__main__":
    main()
