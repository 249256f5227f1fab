"""The errors the readers raise: each names the file and says what is wrong with it."""


class RunDirectoryError(Exception):
    """A run-directory file that cannot be read as documented (docs/run-directory.md)."""


class MissingFileError(RunDirectoryError, FileNotFoundError):
    """A file the call needs is not in the run directory (or the database does not exist)."""


class TruncatedError(RunDirectoryError):
    """A file of a finished run (DONE present) ends in the middle of a block or a row."""


class FormatError(RunDirectoryError, ValueError):
    """A file that is not in the documented format: the message gives file:line and why."""


class NewerFormatError(RunDirectoryError):
    """A run directory written in a format newer than this reader knows."""
