"""The ``brdffit`` command: models, fit, compare, synth, evaluate, serve.

This module holds the parser and :func:`main`; :mod:`.commands` does each
command's work through the library's public calls and :mod:`.text` prints.
Each command reads its arguments, makes one library call and prints the
result: a table for a person, or with ``--json`` one JSON object, the
``to_dict()`` of the result. Errors (bad input, a missing extra) are one line
on stderr and exit code 2. Long work (the global search, the sampling) shows a
progress line on stderr when stderr is a terminal, and never under ``--json``.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings

from .. import __version__
from ..errors import BrdfFitError, MissingExtraError
from ..fitting.losses import LOSSES
from ..fitting.options import COARSE_ABOVE, COARSE_SAMPLES
from . import batch, export
from .commands import (
    AXES,
    cmd_compare,
    cmd_evaluate,
    cmd_fit,
    cmd_models,
    cmd_serve,
    cmd_synth,
)
from .fittable import COMPACT_ABOVE

__all__ = ["build_parser", "main"]


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        # One line, not argparse's usage block: the command, what is wrong, where to look.
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


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
    p.add_argument(
        "file", help="a data file: CSV, ASTM, pbrt .brdf, MERL .binary, MBSDF, NPZ, RGL .bsdf"
    )
    p.add_argument("--format", help="the file's format when its name does not tell it")
    p.add_argument("--subsample", type=_count, help="MERL: keep every k-th cell per axis")
    p.add_argument(
        "--angle-unit",
        choices=("degrees", "radians"),
        help="the unit of the file's angles (CSV: degrees unless stated; ASTM, pbrt: radians)",
    )
    p.add_argument(
        "--loss",
        choices=list(LOSSES),
        help="the loss (default: chi2 when the data give sigma, else mixed: the noise "
        "sigma^2 = a^2 + (b f)^2 estimated with the fit)",
    )
    p.add_argument("--seed", type=_seed, default=0, help="same seed, same result (default 0)")
    p.add_argument("--channels", help="fit only these channels, e.g. r,g,b")
    p.add_argument("--timeout", type=_seconds, help="seconds allowed to each fit")
    p.add_argument("--rgb", action="store_true", help="fit spectral data in linear sRGB (D65)")
    _add_json(p)


def _add_models(sub) -> None:
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


def _add_fit(sub) -> None:
    p = sub.add_parser("fit", help="fit a model to a data file")
    _add_fit_options(p)
    p.add_argument("--model", required=True, help='a model name, or a sum "lambert+blinn"')
    p.add_argument("--fixed", nargs="+", metavar="NAME=VALUE", help="hold parameters fixed")
    p.add_argument("--free", nargs="+", metavar="NAME", help="search parameters held by default")
    p.add_argument(
        "--energy-conserving",
        action="store_true",
        help="keep the directional albedo <= 1 at every incidence angle from 0 to 89 "
        "degrees (enforced on a grid, checked every 2.5 degrees; the message says "
        "the largest albedo found)",
    )
    p.add_argument(
        "--coarse-above",
        type=int,
        metavar="N",
        help=f"above N samples the search runs coarse to fine (default {COARSE_ABOVE})",
    )
    p.add_argument(
        "--coarse-samples",
        type=int,
        metavar="N",
        help=f"the coarse subsample (default {COARSE_SAMPLES})",
    )
    p.add_argument("--uncertainty", action="store_true", help="also sample the posterior")
    p.add_argument(
        "--every-channel",
        action="store_true",
        help=f"a row per channel even above {COMPACT_ABOVE} channels (default: a summary)",
    )
    p.add_argument("--max-seconds", type=_seconds, help="time budget of the sampling (default 60)")
    p.add_argument("--walkers", type=_count, help="emcee walkers (default 32)")
    p.add_argument(
        "--noise",
        choices=("given", "absolute", "relative", "mixed"),
        help="noise model of the posterior (default: the fit's: mixed after a mixed fit, "
        "given when the data have sigma)",
    )
    p.add_argument(
        "--plot",
        metavar="PNG",
        help="plot measured vs fitted (and the corner plot); needs the 'plot' extra",
    )
    export.add_fit_option(p)
    p.set_defaults(run=cmd_fit)


def _add_compare(sub) -> None:
    p = sub.add_parser("compare", help="fit several models and rank them")
    _add_fit_options(p)
    p.add_argument("--models", required=True, help="comma-separated model names")
    p.add_argument("--test-fraction", type=float, default=0.2, help="held-out share (0.2)")
    p.set_defaults(run=cmd_compare)


def _add_synth(sub) -> None:
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


def _add_evaluate(sub) -> None:
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


def _add_serve(sub) -> None:
    p = sub.add_parser("serve", help="run the HTTP service (needs the 'service' extra)")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=_port, default=8000)
    p.add_argument("--workers", type=_count, help="processes running jobs (BRDFFIT_WORKERS, 2)")
    p.add_argument("--fit-workers", type=int, help="processes running POST /fit (0: threads)")
    p.add_argument("--store", help="SQLite file of jobs (BRDFFIT_STORE_PATH)")
    p.add_argument("--log-level", default="info", choices=("debug", "info", "warning", "error"))
    p.add_argument("--insecure", action="store_true",
                   help="serve beyond the loopback without BRDFFIT_API_TOKEN")  # fmt: skip
    p.set_defaults(run=cmd_serve)


def build_parser() -> argparse.ArgumentParser:
    """The parser of every subcommand; each sets ``run``, the function that does it."""
    parser = _Parser(
        prog="brdffit",
        description="Fit analytic BRDF models to measured reflectance, with uncertainties.",
    )
    parser.add_argument("--version", action="version", version=f"brdffit {__version__}")
    sub = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=_Parser
    )
    for add in (_add_models, _add_fit, _add_compare, _add_synth, _add_evaluate, export.add_parser,
                batch.add_parser, _add_serve):  # fmt: skip
        add(sub)
    return parser


# --------------------------------------------------------------------- main
def _warn(message, category, filename, lineno, file=None, line=None):
    sys.stderr.write(f"brdffit: warning: {message}\n")


def _closed_stdout() -> int:
    """The reader of stdout went away (``brdffit models | head``): stop quietly, as a
    command killed by SIGPIPE would, without a traceback when Python flushes stdout."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass  # stdout is not a file (a test's capture): nothing will flush into the pipe
    return 141  # 128 + SIGPIPE


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
        except (BrdfFitError, MissingExtraError) as exc:
            message = str(exc)
        except (FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError) as exc:
            message = f"{exc.filename}: {exc.strerror}"
        except KeyboardInterrupt:
            sys.stderr.write(f"\n{name}: interrupted\n")
            return 130
        except BrokenPipeError:
            return _closed_stdout()
    sys.stderr.write(f"{name}: error: {message}\n")
    return 2


if __name__ == "__main__":
    sys.exit(main())
