"""A shipped network's calibration as one typed, versioned object: :class:`Calibration`.

What it holds (measured by :func:`~nh_operators.solving.calibrate_pretrained`):

* **factor tables**, one per (:class:`~.kinds.InputKind`, :class:`~.kinds.CallKind`): the
  calibrated estimate is ``factors[k] · raw`` for a raw estimate in bin k, the bins split
  at ``limits`` (the raw estimate is first order in the error: as the error grows, its
  ratio to the truth spreads more). Exact potentials (B-splines and formulas) share one
  table; sensor values, whose truth is their spline's trajectory, have their own.
* **acceptance quantiles**: the calibrated estimate on each calibration family at
  ``probabilities``, from which :meth:`Calibration.acceptance_rate` reads how often an
  estimate meets a tolerance.
* **costs**: a call's and a ``solve_many`` row's seconds, for the network and for the
  classical solve per input kind and tolerance (and up to
  :data:`~nh_operators.solving.costs.SHORT_HORIZON`).

On disk it is ``weights/NAME/calibration.json`` in format :data:`FORMAT`;
:meth:`Calibration.from_json` migrates a file of an older format here, and only here.

To add a field: add it to :class:`Calibration`, read it in :meth:`Calibration.from_json`
(with its migration from an older format, if any), write it in :meth:`Calibration.to_json`,
and fill it in :func:`~nh_operators.solving.calibrate.calibrate_factors` or
:func:`~nh_operators.solving.calibrate.measure_costs`.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._constants import TIMES
from .acceptance import SENSOR_FAMILIES
from .costs import horizon_share
from .kinds import CallKind, InputKind

__all__ = ["FORMAT", "Calibration", "costs_from_v1", "factors_from_v1"]

#: The format version :meth:`Calibration.to_json` writes.
FORMAT = 2

_V1_CALLS = {CallKind.PLAIN: "", CallKind.EARLY: "_early", CallKind.FINE: "_fine"}
_V1_KINDS = {InputKind.BSPLINE: "", InputKind.SENSORS: "_sensors",
             InputKind.FORMULA: "_formula"}
_V1_COSTS = ("neural_seconds", "neural_seconds_batched", "classical_tols", "device")


def _frozen(values: Any) -> np.ndarray:
    out = np.array(values, dtype=np.float64)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class Calibration:
    """A network's calibrated estimate, how often it is accepted, and what it costs.

    Attributes:
        limits: raw-estimate bin edges (K - 1,).
        factors: factor per bin (K,), by (input kind, call kind); B-splines and formulas
            share the exact table; a network that does not refine has no ``FINE`` one.
        probabilities: the levels (P,) of every ``estimate_quantiles``.
        estimate_quantiles: the calibrated estimate on the in-distribution family of
            exact potentials at ``probabilities`` (calls of the whole orbit).
        families: per calibration family, as measured (``drawn``, ``admitted``, per-bin
            ``bins``/``bins_early``/``bins_fine`` bounds and ``estimate_quantiles``).
        neural_seconds, neural_seconds_batched: one call's, and one ``solve_many``
            row's, seconds of the network with its estimate.
        classical_tols: tolerances (T,) of the classical timings.
        classical: per input kind, ``"full"`` (one call to t = 2), ``"short"`` (one call
            to :data:`~nh_operators.solving.costs.SHORT_HORIZON`) and, for the kinds
            ``solve_many`` batches, ``"batched"`` (per row): seconds (T,).
        info: the rest, kept as measured (``quantile``, ``confidence``, ``n``,
            ``L_quantiles``, ``estimate_over_true_median``, ``dataset_checksum``,
            ``dataset_draw`` (the draw version of that dataset; absent: draw 1, as in
            every calibration shipped before draw 2), ``ood_seed``, ``initial_state``,
            ``device``).
        version: the format it was read from (:data:`FORMAT` once written again).

    Example:
        >>> cal = Calibration.from_json(EXAMPLE)
        >>> cal.calibrated(np.array([1e-4, 5e-3]), InputKind.SENSORS, CallKind.PLAIN).tolist()
        [5e-05, 0.005]
        >>> cal.acceptance_rate(1e-4, InputKind.BSPLINE)
        0.5
    """

    limits: np.ndarray
    factors: Mapping[tuple[InputKind, CallKind], np.ndarray]
    probabilities: np.ndarray
    estimate_quantiles: np.ndarray
    families: Mapping[str, Mapping[str, Any]]
    neural_seconds: float
    neural_seconds_batched: float
    classical_tols: np.ndarray
    classical: Mapping[InputKind, Mapping[str, np.ndarray]]
    info: Mapping[str, Any] = field(default_factory=dict)
    version: int = FORMAT

    # -- the estimate -------------------------------------------------------------------
    def calibrated(self, raw: np.ndarray | float, kind: InputKind,
                   call: CallKind = CallKind.PLAIN) -> np.ndarray:
        """The calibrated estimate of raw estimates ``raw`` (any shape) for an input of
        ``kind`` and calls of kind ``call``: ``factors[k] · raw`` for raw in bin k;
        infinite for ``FINE`` calls of a network with no such factors.

        Raises:
            ValueError: ``kind`` or ``call`` not one of the enums.
        """
        kind, call = InputKind(kind), CallKind(call)
        raw = np.asarray(raw, dtype=np.float64)
        factors = self.factors.get((kind, call))
        if factors is None:
            return np.full(raw.shape, np.inf)
        return factors[np.searchsorted(self.limits, raw, side="left")] * raw

    def calibrated_calls(self, raw: np.ndarray, kind: InputKind,
                         early: np.ndarray | bool) -> np.ndarray:
        """:meth:`calibrated` for calls that are ``early`` or not, one flag per raw
        estimate (or one for all)."""
        out = self.calibrated(raw, kind, CallKind.PLAIN)
        if np.any(early):
            out = np.where(early, self.calibrated(raw, kind, CallKind.EARLY), out)
        return out

    # -- how often it is accepted -------------------------------------------------------
    def acceptance_rate(self, tol: float, kind: InputKind, family: str | None = None,
                        *, cautious: bool = False) -> float:
        """Share of a calibration family whose calibrated estimate is ≤ tol
        (interpolated between the stored quantiles in log scale).

        Args:
            tol: the tolerance (> 0).
            kind: the input kind; sensor values read the sensor family that mirrors
                ``family`` (:data:`~nh_operators.solving.acceptance.SENSOR_FAMILIES`).
            family: an exact family's name (default: in distribution).
            cautious: the smaller of the share in distribution and on the other
                generator's potentials that the network's domain admits: what a single
                call, which cannot tell which generator its input came from, may count
                on.
        """
        kind = InputKind(kind)
        if cautious:
            shares = [self.acceptance_rate(tol, kind)]
            other = "other distribution"
            if not kind.exact:
                other = SENSOR_FAMILIES[other]
            if "estimate_quantiles" in self.families.get(other, {}):
                shares.append(self._share(tol, other))
            return min(shares)
        if not kind.exact:
            family = SENSOR_FAMILIES[family or "in distribution"]
        return self._share(tol, family)

    def _share(self, tol: float, family: str | None) -> float:
        quantiles = (self.estimate_quantiles if family is None
                     else self.families[family]["estimate_quantiles"])
        est = np.log(np.maximum(quantiles, 1e-300))
        return float(np.interp(np.log(tol), est, self.probabilities, left=0.0, right=1.0))

    # -- what it costs ------------------------------------------------------------------
    def neural_seconds_per(self, batched: bool = False) -> float:
        """The network's seconds: one call's, or one ``solve_many`` row's."""
        return self.neural_seconds_batched if batched else self.neural_seconds

    def classical_seconds(self, tol: float, kind: InputKind, batched: bool = False,
                          horizon: float | None = None) -> float:
        """The classical solve's seconds at ``tol`` for an input ``kind``: one call's, or
        one ``solve_many`` row's (``batched``; formulas are solved one by one there, so
        theirs is one call's), up to the latest time ``horizon`` (default: t = 2).

        Between the short and the whole grid's timing the cost is taken linear in the
        horizon (:func:`~nh_operators.solving.costs.horizon_share`).
        """
        table = self.classical[InputKind(kind)]
        tols = np.log10(self.classical_tols)
        seconds = table["batched"] if batched and "batched" in table else table["full"]
        at = float(np.interp(-np.log10(tol), -tols, seconds))
        if horizon is None or horizon >= TIMES[-1]:
            return at
        full, short = (float(np.interp(-np.log10(tol), -tols, table[f]))
                       for f in ("full", "short"))
        return at * horizon_share(short / full, horizon)

    def expected_seconds(self, tol: float, kind: InputKind, *, batched: bool = False,
                         horizon: float | None = None) -> tuple[float, float, float]:
        """What trying the network first is expected to cost at ``tol``.

        Returns:
            (expected, share, classical): T_net + (1 − share) · T_classical, the share
            accepted (cautious for a single call, in distribution for ``solve_many``,
            which learns the share on its own rows), and T_classical.
        """
        share = self.acceptance_rate(tol, kind, cautious=not batched)
        t_cls = self.classical_seconds(tol, kind, batched, horizon)
        return self.neural_seconds_per(batched) + (1.0 - share) * t_cls, share, t_cls

    # -- the dataset it was measured on --------------------------------------------------
    def check_dataset(self, dataset: Any, name: str = "this network") -> None:
        """Check that ``dataset`` is the one this calibration was measured on.

        The calibration records the dataset's checksum (``info["dataset_checksum"]``)
        and, from draw 2 on, the draw that made it (``info["dataset_draw"]``; the
        shipped calibrations predate it: no key means draw 1, whose bytes depend on the
        CPU). A mismatch names the draw that made the recorded dataset, the one that made
        ``dataset`` and the one this version runs.

        Args:
            dataset: a :class:`~nh_operators.data.Dataset` (or a path to one).
            name: the network's name, for the message.

        Raises:
            ValueError: if the checksums differ (the message says which draws made
                each), or the calibration records no dataset.
        """
        from ..data.generate import checksum_mismatch, load_dataset

        if not hasattr(dataset, "checksum"):
            dataset = load_dataset(dataset)
        recorded = self.info.get("dataset_checksum")
        if recorded is None:
            raise ValueError(f"the calibration of {name} records no dataset checksum")
        if dataset.checksum != recorded:
            raise ValueError(checksum_mismatch(
                f"the dataset {name} was calibrated on", recorded, dataset,
                self.info.get("dataset_draw")))

    # -- files --------------------------------------------------------------------------
    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Calibration:
        """Read a calibration dict of any format (an older one is migrated first).

        Raises:
            ValueError: a format this version cannot read, or an older file without the
                fields a migration needs (calibrate the network again).
        """
        version = data.get("format", 1)
        if version == 1:
            data = _migrated_v1(data)
        elif version != FORMAT:
            raise ValueError(f"calibration format {version!r} is not readable here (this "
                             f"version reads 1 and {FORMAT}); upgrade nh_operators")
        factors: dict[tuple[InputKind, CallKind], np.ndarray] = {}
        for truth, calls in data["factors"].items():
            for call, values in calls.items():
                kinds = [InputKind.SENSORS] if truth == "sensors" else [InputKind.BSPLINE,
                                                                         InputKind.FORMULA]
                for kind in kinds:
                    factors[(kind, CallKind(call))] = _frozen(values)
        costs = data["costs"]
        classical = {InputKind(kind): {phase: _frozen(v) for phase, v in table.items()}
                     for kind, table in costs["classical_seconds"].items()}
        info = dict(data.get("info", {}))
        info["device"] = costs.get("device")
        return cls(limits=_frozen(data["limits"]), factors=factors,
                   probabilities=_frozen(data["probabilities"]),
                   estimate_quantiles=_frozen(data["estimate_quantiles"]),
                   families=data["families"], neural_seconds=float(costs["neural_seconds"]),
                   neural_seconds_batched=float(costs["neural_seconds_batched"]),
                   classical_tols=_frozen(costs["classical_tols"]), classical=classical,
                   info=info, version=version)

    def to_json(self) -> dict[str, Any]:
        """The calibration as a dict in format :data:`FORMAT` (JSON-serialisable)."""
        factors: dict[str, dict[str, list[float]]] = {}
        for (kind, call), values in self.factors.items():
            if kind is not InputKind.FORMULA:  # shares the B-splines' (exact) table
                factors.setdefault(kind.truth, {})[call.value] = values.tolist()
        info = {k: v for k, v in self.info.items() if k != "device"}
        return {"format": FORMAT, "limits": self.limits.tolist(), "factors": factors,
                "probabilities": self.probabilities.tolist(),
                "estimate_quantiles": self.estimate_quantiles.tolist(),
                "families": self.families,
                "costs": {"neural_seconds": self.neural_seconds,
                          "neural_seconds_batched": self.neural_seconds_batched,
                          "classical_tols": self.classical_tols.tolist(),
                          "classical_seconds": {kind.value: {p: v.tolist() for p, v in
                                                             table.items()}
                                                for kind, table in self.classical.items()},
                          "device": self.info.get("device")},
                "info": info}

    @classmethod
    def read(cls, path: str | Path) -> Calibration:
        """:meth:`from_json` of a file."""
        return cls.from_json(json.loads(Path(path).read_text()))

    def dumps(self) -> str:
        """:meth:`to_json` as the text of a file."""
        return json.dumps(self.to_json(), indent=2) + "\n"


def _migrated_v1(old: Mapping[str, Any]) -> dict[str, Any]:
    """A format-1 file (flat keys: ``factors_sensors_early``, ``classical_seconds_formula``
    ...) in format 2. Its scalar ``factor`` (the first bin's) is dropped."""
    missing = [k for k in ("factors_sensors", "factors_early", "factors_sensors_early",
                           "classical_seconds_short", "classical_seconds_sensors_short",
                           "classical_seconds_formula_short",
                           "classical_seconds_sensors_batched", *_V1_COSTS) if k not in old]
    if missing:
        raise ValueError(f"this calibration file predates {', '.join(missing)}: calibrate "
                         "the network again (nh-operators calibrate)")
    return {**factors_from_v1(old), "costs": costs_from_v1(old)}


def factors_from_v1(old: Mapping[str, Any]) -> dict[str, Any]:
    """Everything but the costs of a format-1 dict, in format 2 (``factor``, the first
    bin's, is dropped; the cost fields are ignored)."""
    factors: dict[str, dict[str, Any]] = {}
    for kind in (InputKind.BSPLINE, InputKind.SENSORS):
        for call, suffix in _V1_CALLS.items():
            key = "factors" + _V1_KINDS[kind] + suffix
            if key in old:
                factors.setdefault(kind.truth, {})[call.value] = old[key]
    taken = {"format", "factor", "limits", "probabilities", "estimate_quantiles", "families",
             *_V1_COSTS} | {k for k in old if k.startswith(("factors", "classical_seconds"))}
    return {"format": FORMAT, "limits": old["limits"], "factors": factors,
            "probabilities": old["probabilities"],
            "estimate_quantiles": old["estimate_quantiles"], "families": old["families"],
            "info": {k: v for k, v in old.items() if k not in taken}}


def costs_from_v1(old: Mapping[str, Any]) -> dict[str, Any]:
    """The costs of a format-1 dict (``neural_seconds``, ``classical_seconds_sensors_short``
    ...), as format 2's ``costs``."""
    classical: dict[str, dict[str, Any]] = {}
    for kind, suffix in _V1_KINDS.items():
        base = "classical_seconds" + suffix
        table = {"full": old[base], "short": old[base + "_short"]}
        if base + "_batched" in old:
            table["batched"] = old[base + "_batched"]
        classical[kind.value] = table
    return {**{k: old[k] for k in _V1_COSTS}, "classical_seconds": classical}


#: A small calibration in format 2, for examples and tests.
EXAMPLE: dict[str, Any] = {
    "format": 2, "limits": [1e-3, 1e-2],
    "factors": {"exact": {"plain": [2.0, 3.0, 8.0], "early": [50.0, 50.0, 50.0]},
                "sensors": {"plain": [0.5, 1.0, 4.0], "early": [50.0, 50.0, 50.0]}},
    "probabilities": [0.0, 0.5, 1.0], "estimate_quantiles": [1e-6, 1e-4, 1e-2],
    "families": {"sensors": {"estimate_quantiles": [1e-7, 1e-5, 1e-3]}},
    "costs": {"neural_seconds": 1e-4, "neural_seconds_batched": 1e-5,
              "classical_tols": [1e-3, 1e-6],
              "classical_seconds": {kind: {"full": [1e-4, 1e-3], "short": [5e-5, 5e-4]}
                                    for kind in ("bspline", "sensors", "formula")},
              "device": None},
    "info": {}}
