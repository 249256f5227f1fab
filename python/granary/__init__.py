"""Granary from Python: read a campaign's database and any run directory.

    import granary
    campaign = granary.open("study.db")      # a campaign database
    run = granary.open("runs/0d8bf936c27467b8")  # or one run directory

The readers follow docs/run-directory.md (the C++ readers in src/rundir are the reference);
docs/python.md walks through them."""

import os

from . import formats  # noqa: F401 (granary.formats.register: where a frame format plugs in)
from .bodies import BODY_DTYPE, bodies_of
from .campaign import Campaign, FilterError, short_axis
from .dump import CONTACT_DTYPE, DISC_DTYPE, ContactFrame, DumpReader, Frame
from . import gsdfile  # noqa: F401 (registers frames.gsd and contacts.gsd)
from .errors import FormatError, MissingFileError, NewerFormatError, RunDirectoryError, TruncatedError
from .run import Clog, Run
from .silo import Silo

__all__ = ["open", "open_run", "Campaign", "Run", "Frame", "ContactFrame", "Clog", "Silo", "DumpReader",
           "bodies_of", "short_axis", "DISC_DTYPE", "CONTACT_DTYPE", "BODY_DTYPE", "RunDirectoryError",
           "MissingFileError", "TruncatedError", "FormatError", "NewerFormatError", "FilterError"]


def open(path):  # noqa: A001 (granary.open, as the issue asks)
    """A campaign database (a file: Campaign) or a run directory (a folder: Run)."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise MissingFileError(f"{path}: no such run directory or campaign database")
    if os.path.isdir(path):
        return Run(path)
    return Campaign(path)


def open_run(path):
    """One run directory."""
    return Run(path)
