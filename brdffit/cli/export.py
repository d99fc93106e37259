"""``brdffit export RESULT.json --to TARGET --out FILE`` and ``fit ... --export``.

The result file is what ``brdffit fit --json`` prints (the fit's ``to_dict()``).
The export's conversion error is printed: as a few lines for a person, or with
``--json`` as the export's ``to_dict()``. ``--preview PNG`` writes one picture
(:func:`brdffit.export.preview.write_preview`): the fit's plot against the data
(when the data are at hand), beside a sphere rendered by Mitsuba 3 with the
material's Mitsuba export and, when the data are an RGL ``.bsdf`` file, beside
Mitsuba's ``measured`` rendering of that file.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ..errors import ParameterError
from .text import print_json

__all__ = ["add_parser", "add_fit_option", "check_preview", "export_after_fit", "preview", "run"]

_PREVIEW_HELP = (
    "write a picture: the fit's plot{data} beside a sphere rendered with the material in "
    "Mitsuba (and beside Mitsuba's rendering of RGL .bsdf data); needs the 'export' and "
    "'plot' extras"
)


def add_parser(subparsers) -> None:
    """The ``export`` subcommand."""
    from ..export import export_targets

    targets = export_targets()
    p = subparsers.add_parser("export", help="turn a fit result into a renderer's material")
    p.add_argument("result", metavar="RESULT.json", help="the output of brdffit fit --json")
    p.add_argument("--to", required=True, choices=sorted(targets), help="the renderer")
    p.add_argument("--out", required=True, help="the file to write")
    p.add_argument("--data", help="a data file: fit approximate exports to it, measure on it")
    p.add_argument("--preview", metavar="PNG", help=_PREVIEW_HELP.format(data=" (with --data)"))
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
    parser.add_argument("--preview", metavar="PNG", help=_PREVIEW_HELP.format(data=""))


def check_preview(args) -> None:
    """Before any work: each ``--export`` is TARGET:FILE of a known target, and a
    ``--preview`` needs Mitsuba and matplotlib (one-line errors)."""
    _export_specs(args)
    if getattr(args, "preview", None):
        from ..extras import require

        require("mitsuba", "export")
        require("matplotlib", "plot")


def _export_specs(args) -> list:
    """``(target, file)`` of each ``--export TARGET:FILE``, checked."""
    from ..export import export_targets

    specs = []
    for spec in getattr(args, "export", None) or ():
        target, sep, out = spec.partition(":")
        if not sep or not out:
            raise ParameterError(
                f"--export {spec!r} must be TARGET:FILE, e.g. gltf:m.gltf", "export"
            )
        if target not in export_targets():
            raise ParameterError(
                f"--export {spec!r}: {target!r} is not an export target; choose one of "
                f"{', '.join(export_targets())}",
                "export",
            )
        specs.append((target, out))
    return specs


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


def _do(result, target: str, out: str, data):
    from ..export import export

    e = export(result, target, data=data)
    e.write(out)
    return e


def preview(path: str, result, data, source, exports=()) -> None:
    """``--preview PNG``: write the picture, say so (and what it lacks) on stderr.

    ``source`` is the data file (its name titles the fit's plot; an RGL ``.bsdf``
    file is also rendered by Mitsuba's ``measured`` plugin); ``exports`` those made.
    """
    from ..export import export
    from ..export.preview import NO_DATA, write_preview

    mitsuba = next((e for e in exports if e.target == "mitsuba"), None)
    mitsuba = mitsuba or export(result, "mitsuba", data=data)

    rgl = source if source and Path(source).suffix.lower() == ".bsdf" else None
    write_preview(path, mitsuba, result, data, targets=exports, measured=rgl, title=source)
    missing = "" if data is not None else f"; {NO_DATA} (give --data FILE to draw it)"
    sys.stderr.write(f"wrote {path}{missing}\n")


def run(args) -> int:
    from ..io import read

    check_preview(args)
    data = read(args.data) if args.data else None
    result = _load_result(args.result)
    e = _do(result, args.to, args.out, data)
    if args.preview:
        preview(args.preview, result, data, args.data, [e])
    if args.json:
        return print_json(e.to_dict())
    print(f"wrote {args.out}\n{summary(e)}")
    return 0


def export_after_fit(args, result, data) -> None:
    """Write each ``--export TARGET:FILE`` of a fit and the ``--preview``; report on
    stderr (stdout may be JSON)."""
    made = []
    for target, out in _export_specs(args):
        made.append(_do(result, target, out, data))
        sys.stderr.write(f"wrote {out}\n{summary(made[-1])}\n")
    if getattr(args, "preview", None):
        preview(args.preview, result, data, args.file, made)
