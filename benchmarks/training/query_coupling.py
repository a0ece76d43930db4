"""Does a network's prediction at a time depend on the other times asked with it?

For each network, on the first ``--size`` potentials of a test set (default 200):

1. the *grid call*: all 100 grid times at once, scored against the exact labels
   (its RMS error over potentials, times, q and p);
2. the same grid times asked in other company: each time on its own; random sets of
   3 grid times; every grid time together with 50 random off-grid times;
3. the difference from the grid call at the same times (RMS and largest |Δq|).

The goal of issue 13 §4: RMS Δ below a tenth of the network's own RMS error, for every
way of asking. A network built without self-attention across its queries (TraONet or
MambONet with ``query_attention=False``, DeepONet) passes by construction; the test
measures it anyway.

Run it with::

    python benchmarks/training/query_coupling.py --test paper-test.h5 --run runs/X [--run ...]
        [--pretrained traonet ...]
"""

import argparse

import numpy as np

from nh_operators.data import load_dataset
from nh_operators.models import batched_forward
from nh_operators.training import load_model


def forward(net, V, t):
    return np.concatenate([o.double().cpu().numpy()
                           for _, o in batched_forward(net, V, np.asarray(t)[:, None], 1000)])


def companies(grid, rng, n_random=5):
    """(name, [(times, positions of grid times inside them), ...]) per way of asking."""
    out = [("alone", [(np.array([g]), np.array([0])) for g in grid])]
    sets = []
    for _ in range(n_random):
        pick = np.sort(rng.choice(len(grid), 3, replace=False))
        sets.append((grid[pick], np.arange(3)))
    out.append(("3 random grid times", sets))
    mixed = []
    for _ in range(n_random):
        off = rng.uniform(0, 2, 50)
        times = np.concatenate([grid, off])
        order = np.argsort(times, kind="stable")
        where = np.argsort(order)[:len(grid)]  # positions of the grid times after sorting
        mixed.append((times[order], where))
    out.append(("grid + 50 off-grid", mixed))
    return out


def coupling(net, V, t, q, p, seed=0):
    rng = np.random.default_rng(seed)
    ref = forward(net, V, t)
    truth = np.stack([q, p], axis=-1)
    rms_error = float(np.sqrt(np.mean((ref - truth) ** 2)))
    rows = []
    for name, calls in companies(t, rng):
        sq, n, worst = 0.0, 0, 0.0
        for times, where in calls:
            y = forward(net, V, times)
            grid_idx = np.searchsorted(t, times[where])
            d = y[:, where] - ref[:, grid_idx]
            sq += float(np.sum(d ** 2))
            n += d.size
            worst = max(worst, float(np.max(np.abs(d[..., 0]))))
        rows.append((name, np.sqrt(sq / n), worst))
    return rms_error, rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--test", required=True)
    ap.add_argument("--run", action="append", default=[], help="run directory, repeatable")
    ap.add_argument("--pretrained", action="append", default=[], help="shipped model name")
    ap.add_argument("--size", type=int, default=200)
    args = ap.parse_args()
    ds = load_dataset(args.test)
    V, t, q, p = ds.V[:args.size], ds.t, ds.q[:args.size], ds.p[:args.size]
    nets = [(run, load_model(run)[0]) for run in args.run]
    if args.pretrained:
        from nh_operators.solving import pretrained
        nets += [(name, pretrained(name).net) for name in args.pretrained]
    print(f"{len(V)} potentials of {args.test}; Δ = prediction in other company − grid call")
    print("| network | query_coupled | RMS error (grid call) | asked | RMS Δ | Δ / error "
          "| max abs Δq | goal (Δ < error/10) |")
    print("|" + "---|" * 8)
    for name, net in nets:
        err, rows = coupling(net, V, t, q, p)
        for asked, rms, worst in rows:
            print(f"| {name} | {getattr(net, 'query_coupled', False)} | {err:.2e} | {asked} "
                  f"| {rms:.2e} | {rms / err:.3f} | {worst:.2e} | "
                  f"{'met' if rms < err / 10 else 'missed'} |")


if __name__ == "__main__":
    main()
