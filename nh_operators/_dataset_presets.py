"""The named datasets: size, seed and generator options, one table for library and CLI.

This module imports nothing heavy (no torch, no NumPy), so ``nh-operators generate
--help`` can list the presets without loading the library.

``alg1-*`` (also called ``standard``, ``extended``, ``test``): the paper's Algorithm 1 as
printed, each potential normalised on its own. ``paper-*``: the distribution the paper's
tables were made on, its reference code's (the GRF values of 1.25 n candidates normalised
together; its test set is the last 4,000 of 5,000 drawn from 6,250 candidates). Same
seeds. ``*-states-*``: the same potentials, each from its own bounded state stratified by
energy.
"""

from __future__ import annotations

__all__ = ["DATASET_PRESETS"]

_BASE: dict[str, dict[str, int | str]] = {
    "alg1-standard": {"size": 10_000, "seed": 8407},
    "alg1-extended": {"size": 100_000, "seed": 8407},
    "alg1-test": {"size": 4_000, "seed": 42},
    "paper-standard": {"size": 10_000, "seed": 8407, "normalization": "batch", "pool": 12_500},
    "paper-extended": {"size": 100_000, "seed": 8407, "normalization": "batch",
                       "pool": 125_000},
    "paper-test": {"size": 4_000, "seed": 42, "normalization": "batch", "pool": 6_250,
                   "skip": 1_000},
}


def _table() -> dict[str, dict[str, int | str]]:
    table = dict(_BASE)
    for name, options in _BASE.items():
        family, split = name.split("-")
        table[f"{family}-states-{split}"] = {**options, "states": "energy"}
    for old in ("standard", "extended", "test"):  # the names of earlier releases
        table[old] = table[f"alg1-{old}"]
    return table


#: Preset name → ``generate_dataset`` size, seed and generator options.
DATASET_PRESETS: dict[str, dict[str, int | str]] = _table()
