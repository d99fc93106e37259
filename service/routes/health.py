"""``GET /health``: liveness, version and load."""

from __future__ import annotations

from fastapi import APIRouter

import brdffit

from ..deps import SettingsDep, StoreDep
from ..schemas import HealthOut

__all__ = ["router"]

router = APIRouter(tags=["service"])


@router.get("/health", response_model=HealthOut)
def health(settings: SettingsDep, store: StoreDep):
    """Liveness, the version, the number of job workers and of jobs in each status."""
    return {
        "status": "ok",
        "version": brdffit.__version__,
        "workers": settings.workers,
        "jobs": store.counts(),
    }
