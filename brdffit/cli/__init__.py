"""The ``brdffit`` command line: :mod:`.main` (the parser), :mod:`.commands`
(what each subcommand does, through the library's public calls), :mod:`.text`
(what the commands print)."""

from .main import main

__all__ = ["main"]
