"""Run directories: atomic checkpoints, the config, the loss history, and ``load_model``.

A run directory written by :func:`nh_operators.train` holds

* ``checkpoint.pt`` — model, optimiser and scheduler states, the epoch, RNG states,
  the full config and the dataset checksum (rewritten atomically after every epoch);
* ``config.json`` — the resolved training config;
* ``history.csv`` — one row per epoch: train and validation loss, learning rate, time.
"""

import csv
import io
import json
from pathlib import Path

import torch

from .files import CHECKPOINT, CONFIG, HISTORY, write_atomic

__all__ = ["load_checkpoint", "load_model", "network_from_config", "save_checkpoint",
           "write_history"]

FORMAT = 1


def save_checkpoint(run_dir, state):
    """Atomically write ``state`` (a dict) as ``run_dir/checkpoint.pt``."""
    buf = io.BytesIO()
    torch.save({"format": FORMAT, **state}, buf)
    write_atomic(Path(run_dir) / CHECKPOINT, buf.getvalue())


def write_config(run_dir, config):
    write_atomic(Path(run_dir) / CONFIG,
                 (json.dumps(config, indent=2, sort_keys=True) + "\n").encode())


def write_history(run_dir, history):
    """Atomically write the per-epoch records (list of dicts) as ``history.csv``."""
    if not history:
        return
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=list(history[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(history)
    write_atomic(Path(run_dir) / HISTORY, out.getvalue().encode())


def load_checkpoint(run_dir, map_location="cpu"):
    """The checkpoint dict of a run directory (or of a checkpoint file).

    Raises:
        FileNotFoundError: if there is no checkpoint.
        ValueError: if the file is not an nh-operators checkpoint.
    """
    path = Path(run_dir)
    if path.is_dir():
        path = path / CHECKPOINT
    if not path.is_file():
        raise FileNotFoundError(f"no checkpoint at {str(path)!r}")
    state = torch.load(path, map_location=map_location, weights_only=False)
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        raise ValueError(f"{str(path)!r} is not an nh-operators checkpoint "
                         f"(format {FORMAT})")
    return state


def load_model(run_dir, device="cpu"):
    """Rebuild a trained network from its run directory.

    Args:
        run_dir: folder written by :func:`nh_operators.train` (or its checkpoint file).
        device: where to put the network (default "cpu").

    Returns:
        (network, config): the network in eval mode, in the dtype it was trained in,
        and the run's config dict.

    Raises:
        FileNotFoundError, ValueError: as :func:`load_checkpoint`.

    Example:
        >>> net, config = load_model("runs/traonet")  # doctest: +SKIP
    """
    state = load_checkpoint(run_dir)
    config = state["config"]
    with torch.random.fork_rng(devices=[]):
        net = network_from_config(config)
    net.load_state_dict(state["model"])
    return net.to(device).eval(), config


def network_from_config(config: dict) -> torch.nn.Module:
    """The network a run's config describes, in its dtype, with fresh weights.

    Physics-informed runs (``config["physics"]``) get the starting state as an output
    transform (:func:`~nh_operators.data.state_transform`), as in training.

    Args:
        config: a resolved :class:`~nh_operators.TrainConfig` dict (a run's config.json).

    Returns:
        The network (weights from torch's global generator).

    Raises:
        ValueError: for a physics-informed config (derivative form) whose network couples
            its query times.
    """
    from ..data import state_transform
    from ..models import build_model, cast_network

    net = build_model(config["model"], config["preset"], config.get("variant", "ours"),
                      **config["arch"])
    net = cast_network(net, getattr(torch, config["dtype"]))
    if config.get("physics") is not None:
        pointwise = config["physics"].get("form", "derivative") == "derivative"
        if pointwise and getattr(net, "query_coupled", False):
            raise ValueError(
                f"physics-informed training needs a network that predicts each time on its "
                f"own; this {config['model']} couples its query times: add --arch "
                "query_coupled=False (TrainConfig arch={'query_coupled': False})")
        net.apply_output_transform(state_transform(net.n_sensors, net.initial_state))
    return net
