"""Settings of the HTTP service, read from the environment.

Every setting has an environment variable ``BRDFFIT_<NAME>`` (upper case), for
example ``BRDFFIT_STORE_PATH=/data/jobs.sqlite3`` or ``BRDFFIT_WORKERS=4``. The
limits keep one request from taking the server: a synchronous ``POST /fit``
is bounded in samples and seconds; longer work goes to ``POST /jobs``, which
has its own, larger bounds.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, SecretStr, ValidationError

__all__ = ["ENV_PREFIX", "Settings", "SettingsError"]

ENV_PREFIX = "BRDFFIT_"


class SettingsError(ValueError):
    """An environment variable that does not give a valid setting."""


class Settings(BaseModel):
    """Limits, paths and worker counts of the service (``Settings.from_env()``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    store_path: Path = Field(
        Path("brdffit-jobs.sqlite3"),
        description="SQLite file holding jobs and their results (created if absent).",
    )
    workers: int = Field(2, ge=1, le=256, description="Worker processes running jobs.")
    fit_workers: int = Field(
        0,
        ge=0,
        le=256,
        description="Worker processes running synchronous fits; 0 runs them on the web "
        "process's threads, which use every core as well, the numpy work releasing the GIL "
        "(benchmarks/README.md).",
    )
    max_body_bytes: int = Field(
        64 * 2**20, ge=1024, description="Largest request body accepted; larger ones get 413."
    )
    max_samples: int = Field(
        2_000_000, ge=1, description="Most samples (direction pairs) of a job or an evaluation."
    )
    fit_max_samples: int = Field(
        20_000, ge=1, description="Most samples of a synchronous POST /fit (use /jobs beyond)."
    )
    fit_timeout: float = Field(
        10.0,
        gt=0,
        description="Seconds a synchronous POST /fit may run: the fit's timeout, and the "
        "posterior's max_seconds when uncertainty is asked for.",
    )
    job_timeout: float = Field(
        3600.0, gt=0, description="Seconds a job's fit, and its posterior, may each run."
    )
    scheduler: str | None = Field(
        None,
        max_length=500,
        description="Run jobs on this Dask scheduler (tcp://host:8786), or on a local Dask "
        "cluster of `workers` processes with `local`; unset: the service's own process "
        "pool (dask_runner.py; needs the 'batch' extra).",
    )
    api_token: SecretStr | None = Field(
        None,
        min_length=1,
        description="Bearer token asked of every request but /health, the web page's files "
        "and the API docs (security.py); needed to listen beyond the loopback.",
    )
    allow_no_token: bool = Field(
        False,
        description="Serve beyond the loopback without a token (brdffit serve --insecure): "
        "anyone who reaches the port can then read, cancel and delete every job.",
    )

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None, **overrides) -> Settings:
        """Settings from ``BRDFFIT_*`` variables, then ``overrides`` (keyword arguments)."""
        environ = os.environ if environ is None else environ
        values = {}
        for name in cls.model_fields:
            key = ENV_PREFIX + name.upper()
            if key in environ:
                values[name] = environ[key]
        values.update({k: v for k, v in overrides.items() if v is not None})
        try:
            return cls(**values)
        except ValidationError as exc:
            first = exc.errors()[0]
            name = str(first["loc"][0]) if first["loc"] else "settings"
            shown = "(hidden)" if name == "api_token" else repr(values.get(name))
            raise SettingsError(
                f"{name}={shown} is not a valid setting (environment variable "
                f"{ENV_PREFIX}{name.upper()}): {first['msg']}"
            ) from None
