"""``nh-operators train`` and ``tune``: DeepXDE's loop, and Optuna studies over it."""

import ast
import os

from ._options import (
    existing_file,
    finite_float,
    key_value,
    nonnegative_int,
    positive_float,
    positive_int,
    unit_interval,
)

#: The networks' names (the models wing's MODELS, repeated here so that parsing and
#: ``--help`` do not import torch; tests/cli checks that they agree).
MODEL_NAMES = ("deeponet", "fno", "mambonet", "phaseonet", "traonet", "varonet")


def _arch_overrides(items):
    arch = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--arch takes KEY=VALUE, got {item!r}")
        try:
            arch[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            arch[key] = value
    return arch


def _physics(pairs):
    """``TrainConfig.physics`` of ``--physics KEY=VALUE ...``: None without the flag,
    {} for the flag alone (the residual only, every default)."""
    if pairs is None:
        return None
    physics = {}
    for key, value in pairs:
        if key in physics:
            raise ValueError(f"--physics gives {key!r} twice")
        physics[key] = value
    return physics


def _train(args):
    from ..data import dataset_attrs
    from ..models import count_parameters
    from ..training import TrainConfig, train, tuned_train_kwargs

    dataset_attrs(args.data)  # a clear error now for a file that is not a dataset
    tuned = tuned_train_kwargs(  # --config FILE, explicit flags on top
        args.config, model=args.model, preset=args.preset, arch=_arch_overrides(args.arch),
        lr=args.lr, upper_bound=args.upper_bound, infimum_lr=args.infimum_lr, beta=args.beta)
    config = TrainConfig(**tuned, epochs=args.epochs, seed=args.seed,
                         batch_size=args.batch_size, scheduler=args.scheduler,
                         dtype=args.dtype, device=args.device, amp=args.amp,
                         loss=args.loss, ema=args.ema, variant=args.variant,
                         recipe=args.recipe, scheduler_step=args.scheduler_step,
                         physics=_physics(args.physics))
    net, history = train(config, args.data, args.out, resume=args.resume,
                         progress=not args.quiet, max_minutes=args.max_minutes,
                         stop_after=args.stop_after, max_rows=args.max_rows)
    if os.environ.get("RANK", "0") != "0":
        return  # under torchrun, rank 0 reports
    last = history[-1]
    print(f"{config.model} ({config.preset}, {count_parameters(net)} parameters): "
          f"{last['epoch']} epochs in {last['seconds'] / 60:.1f} min, train loss "
          f"{last['train_loss']:.3e}, validation loss {last['val_loss']:.3e}; "
          f"run directory {args.out}")


def _interrupted(args):
    from ..training import read_history

    try:
        epoch = int(read_history(args.out)["epoch"][-1])
    except (OSError, ValueError, KeyError):
        return f"no epoch finished; nothing kept in {args.out}"
    return (f"the checkpoint of epoch {epoch} is kept in {args.out}; add --resume to the "
            "same command to continue")


def _tune(args):
    import torch

    from .._extras import require

    from ..training import best_config, study_name, tune, tuned_train_kwargs

    optuna = require("optuna")
    optuna.logging.set_verbosity(optuna.logging.WARNING)  # tune prints a line per trial
    if args.threads:
        torch.set_num_threads(args.threads)
    base = tuned_train_kwargs(args.config, model=args.model, arch=_arch_overrides(args.arch))
    model = base.pop("model")
    out = args.out or (args.study or study_name(model, args.stage, args.space)) + ".json"
    study = tune(model, args.stage, args.data, n_trials=args.trials, timeout=args.timeout,
                 storage=args.storage, space=args.space, study=args.study,
                 epochs=args.epochs, seeds=args.seeds, base=base, workdir=args.workdir,
                 out=out, device=args.device)
    best = best_config(study)
    if best is None:
        print(f"{study.study_name}: no trial has completed yet; nothing written")
        return
    info = best["tuning"]
    params = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                       for k, v in info["params"].items())
    print(f"{study.study_name}: best trial {info['trial']} of {sum(info['trials'].values())}"
          f" ({params}): mean validation loss {info['value']:.4g}; written to {out} "
          f"(nh-operators train --config {out} ...)")


def register(sub):
    """Add this module's commands to the subparsers ``sub``."""
    tr = sub.add_parser("train", help="train a network in DeepXDE's loop")
    tr.add_argument("--model", choices=MODEL_NAMES, help="the network (or from --config)")
    tr.add_argument("--variant", choices=["ours", "reference"], default="ours",
                    help="ours (default) or reference: the authors' networks as their "
                    "code builds them (not fno, phaseonet)")
    tr.add_argument("--recipe", choices=["ours", "reference"], default="ours",
                    help="training values left unset: ours (default; the paper's TPE "
                    "optimum, AdamW betas 0.85/0.98) or reference (the authors' code: "
                    "their lr and infimum, betas 0.9/0.999, the schedule per epoch)")
    tr.add_argument("--scheduler-step", choices=["iteration", "epoch"],
                    help="move the lr every iteration or once per epoch (default: the "
                    "recipe's)")
    tr.add_argument("--config", metavar="FILE.json", help="tuned values (nh-operators "
                    "tune --out): arch, lr, upper bound, infimum, beta; flags win")
    tr.add_argument("--preset", choices=["paper", "cpu"],
                    help="architecture preset (default: the config's, else cpu)")
    tr.add_argument("--data", required=True, type=existing_file,
                    help="dataset .h5 (nh-operators generate)")
    tr.add_argument("--epochs", type=positive_int, default=10)
    tr.add_argument("--seed", type=nonnegative_int, default=0)
    tr.add_argument("--out", required=True, help="run directory")
    tr.add_argument("--resume", action="store_true", help="continue a killed run in --out")
    tr.add_argument("--max-minutes", type=positive_float,
                    help="wall-time budget over the whole run; stops after the epoch "
                         "that passes it (checkpoint kept, --resume continues)")
    tr.add_argument("--stop-after", type=positive_int, metavar="EPOCH",
                    help="stop after this epoch of the --epochs schedule (reproduces a "
                         "run that --max-minutes cut)")
    tr.add_argument("--arch", action="append", metavar="KEY=VALUE",
                    help="architecture override, repeatable (e.g. --arch d_model=64)")
    tr.add_argument("--physics", nargs="*", action="extend", type=key_value,
                    metavar="KEY=VALUE", help="learn from Hamilton's equations (their "
                    "residual) instead of the labels; alone: no labels at all; options "
                    "are PhysicsTerms fields, e.g. --physics label_fraction=0.1 "
                    "energy=0.1 (sequence networks need --arch query_coupled=False)")
    tr.add_argument("--batch-size", type=positive_int, default=100)
    tr.add_argument("--lr", type=positive_float, help="initial learning rate (default: paper's)")
    tr.add_argument("--upper-bound", type=positive_float, help="schedule upper bound U")
    tr.add_argument("--infimum-lr", type=positive_float, help="schedule infimum")
    tr.add_argument("--beta", type=finite_float, help="KL weight (VaRONet)")
    tr.add_argument("--scheduler", default="exphyperbolic",
                    choices=["exphyperbolic", "hyperbolic", "constant"])
    tr.add_argument("--loss", default="mse", choices=["mse", "logcosh"],
                    help="training loss (validation is always the paper's MSE)")
    tr.add_argument("--ema", type=unit_interval, default=0.0, metavar="DECAY",
                    help="average the weights (EMA with warm-up, capped at DECAY, e.g. "
                         "0.999); validation and the saved network use the average")
    tr.add_argument("--dtype", default="float32", choices=["float32", "float64"])
    tr.add_argument("--device", default="auto", help="auto, cpu, cuda, cuda:N")
    tr.add_argument("--amp", action="store_true", help="float16 autocast (CUDA only)")
    tr.add_argument("--quiet", action="store_true", help="no progress bar")
    tr.add_argument("--max-rows", type=positive_int, metavar="ROWS",
                    help="most training rows a process holds at once (default: its "
                         "share of an epoch); smaller reads each epoch in several passes")
    tr.set_defaults(run=_train, interrupted=_interrupted)
    tu = sub.add_parser("tune", help="tune with Optuna: stage grid (architecture) or tpe "
                        "(lr, upper bound, infimum, beta); workers may share a study")
    tu.add_argument("--model", choices=MODEL_NAMES, help="the network (or from --config)")
    tu.add_argument("--stage", required=True, choices=["grid", "tpe"])
    tu.add_argument("--data", required=True, type=existing_file,
                    help="dataset .h5 (validation part scores)")
    tu.add_argument("--trials", type=positive_int, help="trials of this worker (default: the "
                    "rest of the grid; tpe needs --trials or --timeout)")
    tu.add_argument("--timeout", type=positive_float, metavar="MINUTES",
                    help="start no trial after")
    tu.add_argument("--storage", default="sqlite:///tune.db", help="Optuna RDB URL")
    tu.add_argument("--study", help="study name (default: MODEL-STAGE-SPACE)")
    tu.add_argument("--space", default="cpu", help="search space: cpu, paper or FILE.json")
    tu.add_argument("--epochs", type=positive_int, help="epochs per run (default: the space's)")
    tu.add_argument("--seeds", type=positive_int,
                    help="runs per trial, averaged (default: space's)")
    tu.add_argument("--config", metavar="FILE.json", help="start from these values (the "
                    "grid stage's best for tpe)")
    tu.add_argument("--arch", action="append", metavar="KEY=VALUE", help="architecture "
                    "override, repeatable")
    tu.add_argument("--out", help="best configuration, JSON (default: STUDY.json)")
    tu.add_argument("--workdir", help="keep run directories here (default: temporary)")
    tu.add_argument("--device", default="auto", help="auto, cpu, cuda, cuda:N")
    tu.add_argument("--threads", type=positive_int, help="torch threads of this worker (CPU: cores "
                    "left free / workers; 1 on a busy machine)")
    tu.set_defaults(run=_tune)
