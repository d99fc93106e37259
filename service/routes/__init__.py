"""The routes, one module per resource; :data:`router` gathers them for the app."""

from fastapi import APIRouter

from . import batches, export, fit, health, jobs, models
from .common import SERVER_ERRORS

__all__ = ["router"]

router = APIRouter(responses=SERVER_ERRORS)
for _module in (health, models, fit, jobs, batches, export):
    router.include_router(_module.router)
