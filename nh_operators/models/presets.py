"""Architecture and training presets: the paper's optimum, and small CPU versions.

``paper``: the architectures of the paper's grid search (its appendix table
"Grid Search Range and Results") and the learning rates, upper bounds, infima and
β of its TPE table. FNO and PhaseONet are not in the paper: their ``paper`` presets
are our choice (PhaseONet: the same size in both presets, chosen by
``benchmarks/cost/fast_operator.py``).

``cpu``: small enough that one epoch on the standard 8,000 training potentials takes
at most a minute on a 2-core CPU (measured by ``benchmarks/cost/model_throughput.py``);
the training values are the paper's.

The ``Literal`` types name the same choices as the tables:

>>> from typing import get_args
>>> get_args(ModelName) == tuple(ARCHITECTURES["paper"]) and get_args(Preset) == PRESETS
True
"""

from typing import Literal

#: The names of the networks (``build_model``'s ``name``).
ModelName = Literal["deeponet", "traonet", "varonet", "mambonet", "fno", "phaseonet"]
#: The architecture presets (``build_model``'s ``preset``).
Preset = Literal["paper", "cpu"]
#: Whose networks: this project's or the authors' (``build_model``'s ``variant``).
Variant = Literal["ours", "reference"]
#: The training recipes (``training_defaults``'s ``recipe``).
RecipeName = Literal["ours", "reference"]

ARCHITECTURES = {
    "paper": {
        "deeponet": dict(hidden_size=128, hidden_layers=3, branches=10),
        "traonet": dict(d_model=64, nhead=8, num_layers=3, dim_feedforward=512),
        "varonet": dict(hidden_size=512, num_layers=4, latent_dim=30),
        "mambonet": dict(d_model=128, num_mamba_layers=4, nhead=4,
                         num_decoder_layers=4, dim_feedforward=1024),
        "fno": dict(n_modes=16, hidden_channels=64, n_layers=4),
        "phaseonet": dict(width=128, depth=2, basis=32, grid=256),
    },
    "cpu": {
        "deeponet": dict(hidden_size=128, hidden_layers=3, branches=10),
        "traonet": dict(d_model=32, nhead=4, num_layers=2, dim_feedforward=128),
        "varonet": dict(hidden_size=64, num_layers=2, latent_dim=16),
        "mambonet": dict(d_model=32, num_mamba_layers=2, nhead=4,
                         num_decoder_layers=2, dim_feedforward=128),
        "fno": dict(n_modes=16, hidden_channels=32, n_layers=4),
        "phaseonet": dict(width=128, depth=2, basis=32, grid=256),
    },
}

#: Sizes of the ``reference`` variants (the authors' networks), in our constructor
#: names. ``paper``: the authors' run configs (DeepONet nodes 128, layers 3, branches 10;
#: VaRONet hidden_size 512, num_layers 4, latent_size 30; TraONet d_model 64, nhead 8,
#: num_layers 3, dim_feedforward 512; MambONet d_model 128, num_layers1 4, n_head 4,
#: num_layers2 4, d_ff 1024), giving their parameter counts 36,650, 63,089,726, 731,778
#: and 2,448,258. ``cpu``: the sizes of our ``cpu`` preset (DeepONet: the paper's).
REFERENCE_ARCHITECTURES = {
    "paper": {
        "deeponet": dict(hidden_size=256, branches=10),
        "traonet": dict(d_model=64, nhead=8, num_layers=3, dim_feedforward=512),
        "varonet": dict(hidden_size=512, num_layers=4, latent_dim=30),
        "mambonet": dict(d_model=128, num_mamba_layers=4, nhead=4,
                         num_decoder_layers=4, dim_feedforward=1024),
    },
    "cpu": {
        "deeponet": dict(hidden_size=256, branches=10),
        "traonet": dict(d_model=32, nhead=4, num_layers=2, dim_feedforward=128),
        "varonet": dict(hidden_size=64, num_layers=2, latent_dim=16),
        "mambonet": dict(d_model=32, num_mamba_layers=2, nhead=4,
                         num_decoder_layers=2, dim_feedforward=128),
    },
}

#: The paper's TPE optimum (ExpHyperbolicLR, AdamW betas (0.85, 0.98), batch 100).
TRAINING = {
    "deeponet": dict(lr=7.3256e-3, upper_bound=300, infimum_lr=1.7369e-3),
    "traonet": dict(lr=1.4645e-3, upper_bound=300, infimum_lr=4.5159e-5),
    "varonet": dict(lr=8.6721e-4, upper_bound=300, infimum_lr=6.2651e-6,
                    beta=5.4963e-2),
    "mambonet": dict(lr=9.7931e-4, upper_bound=350, infimum_lr=1.0310e-5),
    "fno": dict(lr=1e-3, upper_bound=300, infimum_lr=1e-5),
    "phaseonet": dict(lr=2e-3, upper_bound=300, infimum_lr=1e-5),
}

#: The reference recipe (``TrainConfig(recipe="reference")``): the values the authors'
#: run configs at 5c4cbd8 used with AdamW at PyTorch's default betas (0.9, 0.999) and
#: ExpHyperbolicLR stepped once per epoch (upper bound 300), batch 100, MSE. Their
#: MambONet run used lr 1e-3 and infimum 1e-6; FNO and PhaseONet are not theirs and keep
#: their :data:`TRAINING` values.
REFERENCE_TRAINING = {
    "deeponet": dict(lr=7.3256e-3, upper_bound=300, infimum_lr=2.2773e-6),
    "traonet": dict(lr=1.4645e-3, upper_bound=300, infimum_lr=3.0497e-7),
    "varonet": dict(lr=8.6721e-4, upper_bound=300, infimum_lr=6.2651e-6,
                    beta=5.4963e-2),
    "mambonet": dict(lr=1e-3, upper_bound=300, infimum_lr=1e-6),
}

#: Names of the architecture presets: "paper" (the paper's sizes) and "cpu" (smaller).
PRESETS = tuple(ARCHITECTURES)
