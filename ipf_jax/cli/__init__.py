"""Command line: a thin layer over the library, one module per command (see :mod:`.main`)."""
from .main import main

__all__ = ["main"]
