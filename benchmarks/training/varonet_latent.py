"""How much of VaRONet's latent carries information, and what the KL term costs.

For a trained VaRONet run, on the last ``--size`` potentials of a dataset (by default
the validation rows of ``paper-standard``): the posterior σ of each latent dimension
(median over potentials; σ near 1 means the dimension carries nothing), the spread of
its mean μ, the squared error in eval mode (z = μ), and β·KL/(2M), the KL term as the
training loss weighs it per output.

Run it with::

    python benchmarks/training/varonet_latent.py --run final/varonet-paper --data paper-standard.h5
"""

import argparse

import numpy as np
import torch

from nh_operators.data import load_dataset
from nh_operators.training import load_model


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--run", required=True, help="VaRONet run directory")
    ap.add_argument("--data", required=True, help="labelled .h5")
    ap.add_argument("--size", type=int, default=500)
    args = ap.parse_args()
    torch.set_num_threads(1)
    net, config = load_model(args.run)
    data = load_dataset(args.data)
    V = torch.as_tensor(data.V[-args.size:], dtype=torch.float32)
    t = torch.as_tensor(np.asarray(data.t).reshape(-1, 1), dtype=torch.float32)
    y = torch.as_tensor(np.stack([data.q[-args.size:], data.p[-args.size:]], -1),
                        dtype=torch.float32)
    with torch.no_grad():
        mse = float(((net((V, t)) - y) ** 2).mean())
        kl = float(net.kl)
        _, (h, _) = net.encoder(V[..., None])
        mu, logvar = net.mu(h[-1]), net.logvar(h[-1])
    sigma = np.median(torch.exp(0.5 * logvar).numpy(), axis=0)
    used = int((sigma < 0.2).sum())
    print(f"{args.run}: encoder_cell={getattr(net, 'encoder_cell', False)}, "
          f"{args.size} potentials of {args.data}")
    print(f"squared error (eval, z = μ): {mse:.3g}; KL {kl:.3g} nats; "
          f"β·KL/(2M) = {config['beta'] * kl / (2 * t.shape[0]):.3g}")
    print(f"latent dimensions with median σ < 0.2: {used} of {sigma.size}")
    print("median σ per dimension:", " ".join(f"{s:.2f}" for s in sigma))
    print("std of μ per dimension:", " ".join(f"{s:.2f}" for s in mu.std(0).numpy()))


if __name__ == "__main__":
    main()
