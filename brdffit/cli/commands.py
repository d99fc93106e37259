"""What each ``brdffit`` subcommand does: read its arguments, make one library call
(through the public names of :mod:`brdffit`), print the result with :mod:`.text`.

Every ``cmd_*`` takes the parsed arguments and returns the exit code.
"""

from __future__ import annotations

import sys

import numpy as np

import brdffit

from ..errors import BrdfFitError
from ..extras import require
from ..models.base import HIGHLIGHTS, OPERANDS, ORIGINS, SYMMETRIES
from .export import check_preview, export_after_fit
from .text import evaluate_csv, fit_text, models_text, print_json, progress_for, shout

__all__ = [
    "AXES",
    "CliError",
    "cmd_compare",
    "cmd_evaluate",
    "cmd_fit",
    "cmd_models",
    "cmd_serve",
    "cmd_synth",
]

#: The classification axes that ``brdffit models`` filters on, with their values.
AXES = {"origin": ORIGINS, "symmetry": SYMMETRIES, "operand": OPERANDS, "highlight": HIGHLIGHTS}


class CliError(BrdfFitError):
    """A command-line argument the command cannot use."""


# ---------------------------------------------------------------- arguments
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


def assignments(items, option: str) -> dict:
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


def angle_columns(items) -> tuple:
    """``["0,0,30,180", ...]`` (``--angles``) -> four arrays, in degrees."""
    rows = []
    for item in items:
        try:
            rows.append([float(p) for p in item.split(",")])
        except ValueError:
            rows.append([])
        if len(rows[-1]) != 4:
            raise CliError(
                f"--angles {item!r} must be four numbers theta_i,phi_i,theta_o,phi_o in degrees",
                "angles",
            )
    return tuple(np.array(column) for column in zip(*rows))


def read_data(args):
    """``brdffit.read`` of ``args.file`` with ``--format``, ``--subsample``, ``--channels``."""
    options = {"subsample": args.subsample} if getattr(args, "subsample", None) else {}
    if getattr(args, "angle_unit", None):
        options["angle_unit"] = args.angle_unit
    data = brdffit.read(args.file, format=getattr(args, "format", None), **options)
    if getattr(args, "channels", None):
        data = data.select_channels([c.strip() for c in args.channels.split(",") if c.strip()])
    return to_rgb(data) if getattr(args, "rgb", False) else data


def to_rgb(data):
    """``--rgb``: the data in linear sRGB (``Measurements.to_srgb``, units kept: a flat
    spectrum f gives r = g = b = f), or a CliError saying what --rgb needs."""
    if data.wavelengths() is None:
        raise CliError(
            f"--rgb needs spectral channels named like '550nm'; these are "
            f"{', '.join(data.channels)}",
            "rgb",
        )
    return data.to_srgb()


# ----------------------------------------------------------------- commands
def cmd_models(args) -> int:
    """``brdffit.list_models(**filters)``, with ``--properties`` measured per model."""
    filters = {axis: getattr(args, axis) for axis in AXES if getattr(args, axis)}
    if args.wave_optics is not None:
        filters["wave_optics"] = args.wave_optics == "yes"
    models = brdffit.list_models(**filters)
    found = [m.to_dict() for m in models]
    if args.properties:
        from ..models.properties import model_properties

        progress = progress_for(args, "measuring")
        for i, (model, out) in enumerate(zip(models, found)):
            if progress:
                progress.line(f"measuring {model.name} ({i + 1}/{len(models)})")
            out["properties"] = model_properties(model)
        if progress:
            progress.done()
    if args.json:
        return print_json(found)
    print(models_text(found, list(AXES), args.properties))
    return 0


def _fit_options(args, fit_progress, post_progress) -> dict:
    options = dict(
        loss=args.loss,
        seed=args.seed,
        timeout=args.timeout,
        fixed=assignments(args.fixed, "--fixed") or None,
        free=tuple(args.free or ()),
        energy_conserving=args.energy_conserving,
        progress=fit_progress,
    )
    for name in ("coarse_above", "coarse_samples"):  # the library's defaults unless given
        if getattr(args, name) is not None:
            options[name] = getattr(args, name)
    if args.uncertainty:
        posterior = {"progress": post_progress}
        for name in ("walkers", "max_seconds", "noise"):
            if getattr(args, name) is not None:
                posterior[name] = getattr(args, name)
        options.update(uncertainty=True, posterior_options=posterior)
    return options


def cmd_fit(args) -> int:
    """``brdffit.fit(brdffit.read(file), model, **options)``, with ``--plot`` PNGs."""
    if args.plot:
        require("matplotlib", "plot")  # before the fit, not after it
    check_preview(args)
    data = read_data(args)
    fit_progress = progress_for(args, f"fitting {args.model}")
    post_progress = progress_for(args, "sampling", args.max_seconds or 60.0)
    try:
        result = brdffit.fit(data, args.model, **_fit_options(args, fit_progress, post_progress))
    finally:
        for progress in (fit_progress, post_progress):
            if progress:
                progress.done()
    if args.json:
        print_json(result.to_dict())
    else:
        print(fit_text(data, result, args.file, every_channel=args.every_channel))
    if not result.converged:
        shout(f"the fit did not converge: {result.message}",
              "give it more time (--timeout) or check the model and the data")  # fmt: skip
    if result.posterior is not None and not result.posterior.converged:
        shout("THE POSTERIOR DID NOT CONVERGE: the uncertainties above are not reliable.",
              result.posterior.message, "give it more time with --max-seconds")  # fmt: skip
    if args.plot:
        _plots(args.plot, data, result, args.file)
    export_after_fit(args, result, data)
    return 0


def _plots(path: str, data, result, label: str) -> None:
    from ..plot.fit import plot_fit

    written = [plot_fit(data, result, path, title=label)]
    if result.posterior is not None:
        from ..plot.corner import corner_plot

        stem = path[:-4] if path.lower().endswith(".png") else path
        written.append(f"{stem}_corner.png")
        corner_plot(result.posterior, written[-1])
    print(f"wrote {', '.join(str(w) for w in written)}", file=sys.stderr)


def cmd_compare(args) -> int:
    """``brdffit.compare(brdffit.read(file), models, ...)``."""
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    comparison = brdffit.compare(
        read_data(args),
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
    """``brdffit.write(out, brdffit.synthesize(model, params, ...))``."""
    data = brdffit.synthesize(
        args.model,
        assignments(args.params, "--params"),
        geometry=args.geometry,
        noise=args.noise,
        noise_kind=args.noise_kind,
        seed=args.seed,
        n=args.n,
    )
    brdffit.write(args.out, data, format=args.format)
    print(
        f"wrote {data.n} samples ({', '.join(data.channels)}) of {args.model} to {args.out}",
        file=sys.stderr,
    )
    return 0


def cmd_evaluate(args) -> int:
    """``model.evaluate`` at ``--angles`` or at the direction pairs of ``--file``."""
    if bool(args.angles) == bool(args.file):
        raise CliError(
            "give the direction pairs with --angles or with --file, one of the two", "angles"
        )
    model = brdffit.get_model(args.model)
    angles = angle_columns(args.angles) if args.angles else read_data(args).angles()
    pairs = brdffit.Measurements.from_angles(*angles, np.zeros(len(angles[0])))
    params = model.check_params({**model.defaults(), **assignments(args.params, "--params")})
    values = np.asarray(model.evaluate(pairs.wi, pairs.wo, params), dtype=float)
    names = ("theta_i", "phi_i", "theta_o", "phi_o")
    if args.json:
        out = {"model": model.name, "params": params, **dict(zip(names, angles))}
        return print_json(out | {"values": values, "units": "1/sr"})
    print(evaluate_csv(names, angles, values))
    return 0


def cmd_serve(args) -> int:
    """Run the HTTP service (package ``brdffit_service``, folder ``service/``) under uvicorn."""
    for module in ("fastapi", "uvicorn"):
        require(module, "service")
    from brdffit_service import Settings
    from brdffit_service.lock import StoreInUse
    from brdffit_service.server import serve
    from brdffit_service.settings import SettingsError

    try:
        settings = Settings.from_env(
            workers=args.workers, fit_workers=args.fit_workers, store_path=args.store
        )
        # refuses a non-loopback host without a token, and a store another server holds
        serve(settings, args.host, args.port, args.log_level, insecure=args.insecure)
    except (SettingsError, StoreInUse) as exc:
        raise CliError(str(exc), "settings") from None
    return 0
