"""The ``brdffit`` command: models, fit, compare, synth, evaluate, serve.

Each command reads its arguments, makes one library call and prints the
result: a table for a person, or with ``--json`` one JSON object, the
``to_dict()`` of the result. Errors are one line on stderr and exit code 2.
Long work (the global search, the sampling) shows a progress line on stderr
when stderr is a terminal, and never under ``--json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings

import numpy as np

from . import __version__
from .cli_text import fit_text, plain, print_json, progress_for, shout, table
from .errors import BrdfFitError
from .models.base import HIGHLIGHTS, OPERANDS, ORIGINS, SYMMETRIES

__all__ = ["main", "build_parser"]

AXES = {"origin": ORIGINS, "symmetry": SYMMETRIES, "operand": OPERANDS, "highlight": HIGHLIGHTS}


class CliError(BrdfFitError):
    """A command-line argument the command cannot use."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        # One line, not argparse's usage block: the command, what is wrong, where to look.
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


# ------------------------------------------------------------------ parsing
def _number_or_list(text: str, field: str):
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise CliError(
            f"{field}={text!r}: the value must be a number or a list a,b,c", field
        ) from None
    if not values:
        raise CliError(f"{field} has no value; write {field}=0.5 or {field}=0.5,0.4,0.3", field)
    return values[0] if len(values) == 1 else values


def _assignments(items, option: str) -> dict:
    """``["kd=0.5,0.4,0.3", "n=80"]`` -> ``{"kd": [0.5, 0.4, 0.3], "n": 80.0}``."""
    out = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        if not sep or not name.strip():
            raise CliError(
                f"{option} {item!r} must be name=value (e.g. n=80 or kd=0.5,0.4)",
                option.lstrip("-"),
            )
        out[name.strip()] = _number_or_list(text, name.strip())
    return out


def _angles(items) -> tuple:
    rows = []
    for item in items:
        parts = item.split(",")
        try:
            rows.append([float(p) for p in parts])
        except ValueError:
            rows.append([])
        if len(rows[-1]) != 4:
            raise CliError(
                f"--angles {item!r} must be four numbers theta_i,phi_i,theta_o,phi_o in degrees",
                "angles",
            )
    return tuple(np.array(column) for column in zip(*rows))


def _read(args):
    from .io import read

    options = {"subsample": args.subsample} if getattr(args, "subsample", None) else {}
    data = read(args.file, format=getattr(args, "format", None), **options)
    if getattr(args, "channels", None):
        data = data.select_channels([c.strip() for c in args.channels.split(",") if c.strip()])
    return data


# ----------------------------------------------------------------- commands
def cmd_models(args) -> int:
    from .models import list_models

    filters = {axis: getattr(args, axis) for axis in AXES if getattr(args, axis)}
    if args.wave_optics is not None:
        filters["wave_optics"] = args.wave_optics == "yes"
    models = list_models(**filters)
    found = [m.to_dict() for m in models]
    if args.properties:
        from .properties import model_properties

        progress = progress_for(args, "measuring")
        for i, (model, out) in enumerate(zip(models, found)):
            if progress:
                progress.line(f"measuring {model.name} ({i + 1}/{len(models)})")
            out["properties"] = model_properties(model)
        if progress:
            progress.done()
    if args.json:
        return print_json(found)
    header = ["model", *AXES, "wave", "parameters"]
    header += ["max albedo", "albedo <= 1", "reciprocity error"] if args.properties else []
    rows = []
    for m in found:
        c, p = m["classification"], m.get("properties")
        rows.append([m["name"], *(c[axis] for axis in AXES), "yes" if c["wave_optics"] else "no",
                     ", ".join(q["name"] for q in m["params"])])  # fmt: skip
        if p:
            rows[-1] += [f"{np.max(p['max_albedo']):.3g}", "yes" if p["energy_conserving"] else
                         "NO", f"{p['reciprocity_max']:.1e}"]  # fmt: skip
    print(table(header, rows) if rows else "no model matches these filters")
    if args.properties:
        print("\nat each model's default parameters; albedo over theta_i = 0..85 degrees; "
              "reciprocity: largest |f(L,V) - f(V,L)| / max f")  # fmt: skip
    return 0


def _posterior_options(args, progress) -> dict:
    options = {"progress": progress}
    for name in ("walkers", "max_seconds", "noise"):
        if getattr(args, name) is not None:
            options[name] = getattr(args, name)
    return options


def cmd_fit(args) -> int:
    from .fitting import fit

    data = _read(args)
    fit_progress = progress_for(args, f"fitting {args.model}")
    post_progress = progress_for(args, "sampling", args.max_seconds or 60.0)
    options = dict(
        loss=args.loss,
        seed=args.seed,
        timeout=args.timeout,
        fixed=_assignments(args.fixed, "--fixed") or None,
        free=tuple(args.free or ()),
        energy_conserving=args.energy_conserving,
        progress=fit_progress,
    )
    if args.uncertainty:
        options.update(uncertainty=True, posterior_options=_posterior_options(args, post_progress))
    try:
        result = fit(data, args.model, **options)
    finally:
        for progress in (fit_progress, post_progress):
            if progress:
                progress.done()
    print(json.dumps(plain(result.to_dict()), indent=2) if args.json else
          fit_text(data, result, args.file))  # fmt: skip
    if not result.converged:
        shout(f"the fit did not converge: {result.message}",
               "give it more time (--timeout) or check the model and the data")  # fmt: skip
    if result.posterior is not None and not result.posterior.converged:
        shout("THE POSTERIOR DID NOT CONVERGE: the uncertainties above are not reliable.",
               result.posterior.message, "give it more time with --max-seconds")  # fmt: skip
    if args.plot:
        _plots(args.plot, data, result, args.file)
    return 0


def _plots(path: str, data, result, label: str) -> None:
    from .plot_fit import plot_fit

    written = [plot_fit(data, result, path, title=label)]
    if result.posterior is not None:
        from .plots import corner_plot

        stem = path[:-4] if path.lower().endswith(".png") else path
        written.append(f"{stem}_corner.png")
        corner_plot(result.posterior, written[-1])
    print(f"wrote {', '.join(str(w) for w in written)}", file=sys.stderr)


def cmd_compare(args) -> int:
    from .compare import compare

    models = [m.strip() for m in args.models.split(",") if m.strip()]
    comparison = compare(
        _read(args),
        models,
        loss=args.loss,
        seed=args.seed,
        test_fraction=args.test_fraction,
        timeout=args.timeout,
    )
    if args.json:
        return print_json(comparison.to_dict())
    print(comparison)
    print(
        f"best by BIC: {comparison.best_by_bic}; best on the held-out samples: "
        f"{comparison.best_by_heldout}"
    )
    return 0


def cmd_synth(args) -> int:
    from .io import write
    from .synth import synthesize

    data = synthesize(
        args.model,
        _assignments(args.params, "--params"),
        geometry=args.geometry,
        noise=args.noise,
        noise_kind=args.noise_kind,
        seed=args.seed,
        n=args.n,
    )
    write(args.out, data, format=args.format)
    print(
        f"wrote {data.n} samples ({', '.join(data.channels)}) of {args.model} to {args.out}",
        file=sys.stderr,
    )
    return 0


def cmd_evaluate(args) -> int:
    from .measurements import Measurements
    from .models import get_model

    if bool(args.angles) == bool(args.file):
        raise CliError(
            "give the direction pairs with --angles or with --file, one of the two", "angles"
        )
    model = get_model(args.model)
    angles = _angles(args.angles) if args.angles else _read(args).angles()
    pairs = Measurements.from_angles(*angles, np.zeros(len(angles[0])))
    params = model.check_params({**model.defaults(), **_assignments(args.params, "--params")})
    values = np.asarray(model.evaluate(pairs.wi, pairs.wo, params), dtype=float)
    names = ("theta_i", "phi_i", "theta_o", "phi_o")
    if args.json:
        out = {"model": model.name, "params": params, **dict(zip(names, angles))}
        return print_json(out | {"values": values, "units": "1/sr"})
    columns = values.reshape(len(values), -1)
    width = columns.shape[1]
    channels = {1: ["value"], 3: ["r", "g", "b"]}.get(width, [f"c{i}" for i in range(width)])
    print(",".join([*names, *channels]))
    for row in zip(*angles, *columns.T):
        print(",".join(repr(float(x)) for x in row))
    return 0


def cmd_serve(args) -> int:
    import uvicorn

    from service import Settings, create_app
    from service.settings import SettingsError

    try:
        settings = Settings.from_env(
            workers=args.workers, fit_workers=args.fit_workers, store_path=args.store
        )
    except SettingsError as exc:
        raise CliError(str(exc), "settings") from None
    print(
        f"brdffit {__version__}: http://{args.host}:{args.port}/docs, jobs in "
        f"{settings.store_path} ({settings.workers} workers)",
        file=sys.stderr,
    )
    uvicorn.run(create_app(settings), host=args.host, port=args.port, log_level=args.log_level)
    return 0


# ------------------------------------------------------------------- parser
def _add_json(p) -> None:
    p.add_argument("--json", action="store_true", help="print one JSON object (to_dict())")


def _number(kind, low, high, what: str):
    """An argparse type: a ``kind`` in (low, high], or [low, high] for whole numbers."""

    def parse(text):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        above = value >= low if kind is int else value > low
        if not (above and value <= high):
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}")
        return value

    return parse


_seconds = _number(float, 0.0, 1e9, "a positive number of seconds")
_seed = _number(int, 0, 2**32 - 1, "a whole number in [0, 2**32)")
_port = _number(int, 1, 65535, "a port number (1 to 65535)")
_count = _number(int, 1, 10**9, "a whole number >= 1")


def _add_fit_options(p) -> None:
    from .losses import LOSSES

    p.add_argument(
        "file", help="a data file: CSV, ASTM, pbrt .brdf, MERL .binary, MBSDF, NPZ, RGL .bsdf"
    )
    p.add_argument("--format", help="the file's format when its name does not tell it")
    p.add_argument("--subsample", type=_count, help="MERL: keep every k-th cell per axis")
    p.add_argument(
        "--loss",
        choices=list(LOSSES),
        help="the loss (default: chi2 when the data give sigma, else l2)",
    )
    p.add_argument("--seed", type=_seed, default=0, help="same seed, same result (default 0)")
    p.add_argument("--channels", help="fit only these channels, e.g. r,g,b")
    p.add_argument("--timeout", type=_seconds, help="seconds allowed to each fit")
    _add_json(p)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="brdffit",
        description="Fit analytic BRDF models to measured reflectance, with uncertainties.",
    )
    parser.add_argument("--version", action="version", version=f"brdffit {__version__}")
    sub = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=_Parser
    )

    p = sub.add_parser("models", help="list the models and their classification")
    for axis, choices in AXES.items():
        p.add_argument(f"--{axis}", choices=choices)
    p.add_argument("--wave-optics", choices=("yes", "no"))
    p.add_argument(
        "--properties",
        action="store_true",
        help="measure albedo and reciprocity at the default parameters (slower)",
    )
    _add_json(p)
    p.set_defaults(run=cmd_models)

    p = sub.add_parser("fit", help="fit a model to a data file")
    _add_fit_options(p)
    p.add_argument("--model", required=True, help='a model name, or a sum "lambert+blinn"')
    p.add_argument("--fixed", nargs="+", metavar="NAME=VALUE", help="hold parameters fixed")
    p.add_argument("--free", nargs="+", metavar="NAME", help="search parameters held by default")
    p.add_argument(
        "--energy-conserving",
        action="store_true",
        help="keep the directional albedo <= 1 at every incidence",
    )
    p.add_argument("--uncertainty", action="store_true", help="also sample the posterior")
    p.add_argument("--max-seconds", type=_seconds, help="time budget of the sampling (default 60)")
    p.add_argument("--walkers", type=_count, help="emcee walkers (default 32)")
    p.add_argument(
        "--noise",
        choices=("given", "absolute", "relative"),
        help="noise model of the posterior (default: given when the data have sigma)",
    )
    p.add_argument("--plot", metavar="PNG", help="plot measured vs fitted (and the corner plot)")
    p.set_defaults(run=cmd_fit)

    p = sub.add_parser("compare", help="fit several models and rank them")
    _add_fit_options(p)
    p.add_argument("--models", required=True, help="comma-separated model names")
    p.add_argument("--test-fraction", type=float, default=0.2, help="held-out share (0.2)")
    p.set_defaults(run=cmd_compare)

    p = sub.add_parser("synth", help="write synthetic measurements of a model")
    p.add_argument("--model", required=True)
    p.add_argument("--params", nargs="*", metavar="NAME=VALUE", help="defaults where not given")
    p.add_argument("--geometry", default="gonio", choices=("gonio", "hemisphere", "merl"))
    p.add_argument("--noise", type=float, default=0.0, help="noise standard deviation (0)")
    p.add_argument("--noise-kind", default="relative", choices=("relative", "absolute"))
    p.add_argument("--n", type=_count, help="number of samples (hemisphere) or a random subset")
    p.add_argument("--seed", type=_seed, default=0)
    p.add_argument("--format", help="output format (default: from the extension)")
    p.add_argument("--out", required=True, help="the file to write")
    p.set_defaults(run=cmd_synth)

    p = sub.add_parser("evaluate", help="evaluate a model at direction pairs")
    p.add_argument("--model", required=True)
    p.add_argument("--params", nargs="*", metavar="NAME=VALUE", help="defaults where not given")
    p.add_argument(
        "--angles",
        action="append",
        metavar="TI,PI,TO,PO",
        help="a direction pair in degrees (repeatable)",
    )
    p.add_argument("--file", help="take the direction pairs of a data file")
    _add_json(p)
    p.set_defaults(run=cmd_evaluate)

    p = sub.add_parser("serve", help="run the HTTP service")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=_port, default=8000)
    p.add_argument("--workers", type=_count, help="processes running jobs (BRDFFIT_WORKERS, 2)")
    p.add_argument("--fit-workers", type=int, help="processes running POST /fit (0: threads)")
    p.add_argument("--store", help="SQLite file of jobs (BRDFFIT_STORE_PATH)")
    p.add_argument("--log-level", default="info", choices=("debug", "info", "warning", "error"))
    p.set_defaults(run=cmd_serve)

    from .cli_batch import add_parser as add_batch

    add_batch(sub)
    return parser


# --------------------------------------------------------------------- main
def _warn(message, category, filename, lineno, file=None, line=None):
    sys.stderr.write(f"brdffit: warning: {message}\n")


def main(argv=None) -> int:
    """Run the command line; return the exit code (0, or 2 for bad input)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    name = f"brdffit {args.command}"
    with warnings.catch_warnings():
        warnings.showwarning = _warn
        try:
            return args.run(args)
        except BrdfFitError as exc:
            message = str(exc)
        except (FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError) as exc:
            message = f"{exc.filename}: {exc.strerror}"
        except KeyboardInterrupt:
            sys.stderr.write(f"\n{name}: interrupted\n")
            return 130
    sys.stderr.write(f"{name}: error: {message}\n")
    return 2


if __name__ == "__main__":
    sys.exit(main())
