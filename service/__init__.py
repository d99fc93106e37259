"""The HTTP service of brdffit: ``create_app(settings)`` builds the FastAPI app."""

from .app import create_app
from .settings import Settings

__all__ = ["Settings", "create_app"]
