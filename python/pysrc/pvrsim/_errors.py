"""The exceptions of pvrsim. Every one carries the command line's message.

``Error`` is the base of all of them; each also derives from the built-in
exception a Python user would catch for that kind of failure:

=====================  ==========================  =========================================
class                  also a                      raised when
=====================  ==========================  =========================================
``OptionError``        ``ValueError``              an option does not parse or is refused by
                                                   the validation (``ert=1.5``); ``.option``
                                                   names the keyword when the message does
``UnknownOptionError`` ``OptionError``,            a keyword is not an option of the command
                       ``TypeError``
``DataError``          ``ValueError``              arrays handed in are malformed (shape,
                                                   NaN, indices out of range, spacing)
``FileError``          ``OSError``                 a file is missing, unreadable or malformed;
                                                   ``.filename`` is the file, the message
                                                   names the line or field
``RunError``           ``RuntimeError``            a job failed otherwise (a transport, too
                                                   little memory, an internal error)
=====================  ==========================  =========================================

Ctrl-C during a job raises ``KeyboardInterrupt`` as usual.
"""

from __future__ import annotations

from typing import Optional

__all__ = [
    "Error",
    "OptionError",
    "UnknownOptionError",
    "DataError",
    "FileError",
    "RunError",
]


class Error(Exception):
    """Base class of every error pvrsim raises."""


class OptionError(Error, ValueError):
    """An option is malformed or refused (the command line's message).

    ``option`` is the keyword the message is about, when it names one.
    """

    option: Optional[str] = None


class UnknownOptionError(OptionError, TypeError):
    """A keyword that is not an option of the command."""


class DataError(Error, ValueError):
    """Arrays handed to pvrsim are malformed (the message says which and where)."""


class FileError(Error, OSError):
    """A file is missing, unreadable or malformed.

    ``filename`` is the file; the message names the line or field.
    """

    def __str__(self) -> str:
        # The message as given (OSError would print "[Errno None] None: FILE"
        # once ``filename`` is set).
        return str(self.args[0]) if self.args else ""


class RunError(Error, RuntimeError):
    """A job failed for a reason that is neither an option nor a file."""
