"""``brdffit export RESULT.json --to TARGET --out FILE`` and ``fit ... --export``.

The result file is what ``brdffit fit --json`` prints (the fit's ``to_dict()``).
The export's conversion error is printed: as a few lines for a person, or with
``--json`` as the export's ``to_dict()``. ``--preview PNG`` renders a sphere
with the material in Mitsuba 3 (beside Mitsuba's ``measured`` rendering of the
data when ``--data`` is an RGL ``.bsdf`` file).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ..errors import ParameterError
from .text import print_json

__all__ = ["add_parser", "add_fit_option", "run", "export_after_fit"]


def add_parser(subparsers) -> None:
    """The ``export`` subcommand."""
    from ..export import export_targets

    targets = export_targets()
    p = subparsers.add_parser("export", help="turn a fit result into a renderer's material")
    p.add_argument("result", metavar="RESULT.json", help="the output of brdffit fit --json")
    p.add_argument("--to", required=True, choices=sorted(targets), help="the renderer")
    p.add_argument("--out", required=True, help="the file to write")
    p.add_argument("--data", help="a data file: fit approximate exports to it, measure on it")
    p.add_argument(
        "--preview",
        metavar="PNG",
        help="render a sphere with it in Mitsuba (beside the measurement for RGL .bsdf data)",
    )
    p.add_argument("--json", action="store_true", help="print the export as one JSON object")
    p.set_defaults(run=run)


def add_fit_option(parser) -> None:
    """``--export TARGET:FILE`` of ``brdffit fit`` (repeatable)."""
    parser.add_argument(
        "--export",
        action="append",
        metavar="TARGET:FILE",
        help="also export the fitted material (repeatable), e.g. gltf:material.gltf",
    )


def _load_result(path: str) -> dict:
    try:
        text = Path(path).read_text()
    except UnicodeDecodeError:
        raise ParameterError(
            f"{path} is not a text file; give brdffit fit --json output", "result"
        ) from None
    try:
        result = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ParameterError(
            f"{path} is not JSON ({exc.msg} at line {exc.lineno}); give brdffit fit --json output",
            "result",
        ) from None
    if not isinstance(result, dict):
        raise ParameterError(
            f"{path} holds a JSON {type(result).__name__}, not a fit result", "result"
        )
    return result


def summary(e) -> str:
    """A few lines: where the error stands against the fit's own."""
    err = e.conversion_error
    kind = "exact" if err["exact"] else "approximate"
    lines = [
        f"{e.target}: {kind}; RMS of ln(1 + f cos) against the {err['against']} "
        f"({err['n_directions']} directions): {err['rms_log_target']:.4g} "
        f"(the fit's own: {err['rms_log_fit']:.4g})",
        "albedo at " + ", ".join(f"{t:g}" for t in err["albedo_theta_i"]) + " deg: "
        + "; ".join(_row(a) for a in err["albedo_target"]) + " (fit: "
        + "; ".join(_row(a) for a in err["albedo_fit"]) + ")",
    ]  # fmt: skip
    lines += [f"note: {n}" for n in e.notes]
    return "\n".join(lines)


def _row(values) -> str:
    return " ".join(f"{v:.3f}" for v in values)


def _do(result, target: str, out: str, data, preview: str | None, rgl=None):
    from ..export import export
    from ..export.preview import render_preview

    e = export(result, target, data=data)
    e.write(out)
    if preview:
        mitsuba = e if target == "mitsuba" else export(result, "mitsuba", data=data)
        render_preview(mitsuba.document, preview, measured=rgl)
    return e


def run(args) -> int:
    from ..io import read

    data = read(args.data) if args.data else None
    # An RGL file is also rendered by Mitsuba's own measured BSDF, beside the export.
    rgl = args.data if args.data and Path(args.data).suffix == ".bsdf" else None
    e = _do(_load_result(args.result), args.to, args.out, data, args.preview, rgl)
    if args.json:
        return print_json(e.to_dict())
    print(f"wrote {args.out}\n{summary(e)}")
    return 0


def export_after_fit(args, result, data) -> None:
    """Write each ``--export TARGET:FILE`` of a fit; report on stderr (stdout may be JSON)."""
    for spec in getattr(args, "export", None) or ():
        target, sep, out = spec.partition(":")
        if not sep or not out:
            raise ParameterError(
                f"--export {spec!r} must be TARGET:FILE, e.g. gltf:m.gltf", "export"
            )
        e = _do(result, target, out, data, None)
        sys.stderr.write(f"wrote {out}\n{summary(e)}\n")
