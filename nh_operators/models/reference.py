"""The authors' networks as DeepXDE networks: :func:`from_reference` and the registry.

The ``reference`` variant of each architecture computes the function the paper authors'
network computes (their ``model.py`` at commit 5c4cbd8), weight for weight, under their
``state_dict`` key names. :func:`from_reference` turns their ``net_config`` and a
checkpoint into one; ``build_model(name, preset, variant="reference")`` builds a fresh
one to train. ``docs/models.md`` lists how they differ from ours.
"""

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import torch

from .reference_nets import ReferenceDeepONet, ReferenceVaRONet
from .reference_transformers import ReferenceMambONet, ReferenceTraONet

__all__ = ["REFERENCE_MODELS", "from_reference", "reference_arguments"]

#: name → the reference variant's class.
REFERENCE_MODELS = {
    "deeponet": ReferenceDeepONet,
    "traonet": ReferenceTraONet,
    "varonet": ReferenceVaRONet,
    "mambonet": ReferenceMambONet,
}

# the authors' net_config key → our constructor argument, per network
_RENAME = {
    "deeponet": {"branches": "branches"},  # nodes and layers give hidden_size
    "varonet": {"hidden_size": "hidden_size", "num_layers": "num_layers",
                "latent_size": "latent_dim", "dropout": "dropout", "kl_weight": "kl_weight"},
    "traonet": {"d_model": "d_model", "nhead": "nhead", "num_layers": "num_layers",
                "dim_feedforward": "dim_feedforward", "dropout": "dropout"},
    "mambonet": {"d_model": "d_model", "num_layers1": "num_mamba_layers", "n_head": "nhead",
                 "num_layers2": "num_decoder_layers", "d_ff": "dim_feedforward"},
}
_DEEPONET_WIDTH = {"nodes": 128, "layers": 3}  # the authors' paper values


def _check_name(name):
    if name not in REFERENCE_MODELS:
        raise ValueError(f"no reference variant of {name!r}; choose from "
                         f"{sorted(REFERENCE_MODELS)}")


def reference_arguments(name, **net_config):
    """Our constructor arguments for the authors' ``net_config``.

    Keys the config leaves out take the authors' paper values. DeepONet's hidden width
    is ``nodes * (layers - 1)``, the one hidden layer the authors' code builds.

    Args:
        name: "deeponet", "traonet", "varonet" or "mambonet".
        **net_config: the authors' keys: ``nodes``, ``layers``, ``branches`` (DeepONet);
            ``hidden_size``, ``num_layers``, ``latent_size``, ``dropout``, ``kl_weight``
            (VaRONet); ``d_model``, ``nhead``, ``num_layers``, ``dim_feedforward``,
            ``dropout`` (TraONet); ``d_model``, ``num_layers1``, ``n_head``,
            ``num_layers2``, ``d_ff`` (MambONet).

    Returns:
        dict of keyword arguments of ``REFERENCE_MODELS[name]``.

    Raises:
        ValueError: for an unknown name, a key the authors' network does not take
            (naming it), or a DeepONet with fewer than 2 ``layers``.

    Example:
        >>> reference_arguments("deeponet", nodes=16, layers=3, branches=5)
        {'hidden_size': 32, 'branches': 5}
        >>> reference_arguments("mambonet", num_layers1=2, n_head=4)
        {'num_mamba_layers': 2, 'nhead': 4}
    """
    _check_name(name)
    rename = _RENAME[name]
    known = set(rename) | (set(_DEEPONET_WIDTH) if name == "deeponet" else set())
    unknown = sorted(set(net_config) - known)
    if unknown:
        raise ValueError(f"the authors' {name} takes no net_config key(s) {unknown}; it "
                         f"takes {sorted(known)}")
    args = {rename[k]: v for k, v in net_config.items() if k in rename}
    if name == "deeponet":
        width = {**_DEEPONET_WIDTH, **{k: net_config[k] for k in _DEEPONET_WIDTH
                                       if k in net_config}}
        if width["layers"] < 2:
            raise ValueError(f"the authors' DeepONet needs layers >= 2 (its hidden width "
                             f"is nodes * (layers - 1)), got layers={width['layers']}")
        args = {"hidden_size": width["nodes"] * (width["layers"] - 1), **args}
    return args


def _load_state(state_dict_or_path):
    state = state_dict_or_path
    if isinstance(state, (str, Path)):
        state = torch.load(state, map_location="cpu", weights_only=True)
    if not isinstance(state, Mapping):
        raise TypeError(f"expected a state_dict (a mapping of names to tensors) or the path "
                        f"of a .pt file holding one; got {type(state).__name__}")
    out = {}
    for key, value in state.items():
        if not isinstance(value, (torch.Tensor, np.ndarray)):
            raise TypeError(f"state_dict entry {key!r} is a {type(value).__name__}, "
                            f"not a tensor")
        out[key] = torch.as_tensor(value)
    return out


def _check_keys(name, net, state, config):
    own = net.state_dict()
    missing = sorted(set(own) - set(state))
    unexpected = sorted(set(state) - set(own))
    wrong = [f"{k}: checkpoint {tuple(state[k].shape)}, network {tuple(own[k].shape)}"
             for k in sorted(set(own) & set(state)) if state[k].shape != own[k].shape]
    problems = []
    if missing:
        problems.append(f"missing key(s) {missing}")
    if unexpected:
        problems.append(f"unexpected key(s) {unexpected}")
    if wrong:
        problems.append("shape mismatch " + "; ".join(wrong))
    if problems:
        raise ValueError(f"the checkpoint does not fit the reference {name} built from "
                         f"net_config {config} (missing keys take the paper's values): "
                         + "; ".join(problems))


def from_reference(name, state_dict_or_path, **net_config):
    """Our DeepXDE network computing what the authors' network with these weights computes.

    Builds the ``reference`` variant of ``name`` (:data:`REFERENCE_MODELS`) from the
    authors' ``net_config`` and loads their checkpoint into it under their own key
    names, strictly. The network takes the checkpoint's floating dtype (the authors'
    float32, or float64 for a cast one) and is returned in eval mode (VaRONet: z = μ).

    It takes ``(V, t)`` with t of shape (M, 1), shared by the batch, where the authors'
    takes times per row. Their TraONet and MambONet encode a query by its index on
    :data:`~nh_operators.TIMES`; ours encodes t · 99/2, which is the same on that grid.
    The decoders of TraONet, MambONet and VaRONet couple the query times (attention
    across them; a bidirectional LSTM reading them), so predict on ``TIMES``
    (:func:`~nh_operators.predict` warns otherwise).

    Args:
        name: "deeponet", "traonet", "varonet" or "mambonet".
        state_dict_or_path: the authors' ``model.state_dict()`` (tensors or arrays), or
            the path of a ``.pt`` file holding one.
        **net_config: the authors' ``net_config`` keys (see
            :func:`reference_arguments`); keys left out take the paper's values.

    Returns:
        The network (a ``deepxde.nn.pytorch.NN``) on the CPU, in eval mode.

    Raises:
        ValueError: for an unknown name or ``net_config`` key, or a checkpoint whose keys
            or shapes do not fit (naming the missing and unexpected keys and the
            mismatched shapes).
        TypeError: if the checkpoint is not a mapping of names to tensors.

    Example:
        >>> import torch
        >>> from nh_operators.models import build_model
        >>> theirs = build_model("traonet", "cpu", variant="reference").state_dict()
        >>> net = from_reference("traonet", theirs, d_model=32, nhead=4, num_layers=2,
        ...                      dim_feedforward=128)
        >>> net((torch.zeros(2, 100), torch.linspace(0, 2, 100)[:, None])).shape
        torch.Size([2, 100, 2])
    """
    args = reference_arguments(name, **net_config)
    state = _load_state(state_dict_or_path)
    net = REFERENCE_MODELS[name](**args)
    dtypes = {v.dtype for v in state.values() if v.is_floating_point()}
    if len(dtypes) == 1:
        net = net.to(dtypes.pop())
    _check_keys(name, net, state, net_config)
    net.load_state_dict(state, strict=True)
    return net.eval()
