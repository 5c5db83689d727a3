"""The exceptions of ``reflect``: one base class, :class:`Error`, and subclasses of the built-in
classes a caller already catches, so ``except ValueError`` keeps working.

- :class:`InputError` (``ValueError``): a bad argument or bad input data. The message names the
  keyword (``spp=``, ``target_rel_error=``) or the file, in this API's terms.
- :class:`FileError` (``OSError``): a file that cannot be read or written;
  :class:`MissingFileError` (also ``FileNotFoundError``) when it does not exist.
"""


class Error(Exception):
    """Base class of every error ``reflect`` raises on bad input (not of ``KeyboardInterrupt``)."""


class InputError(Error, ValueError):
    """A bad argument or bad input data (a ``ValueError``); the message names the keyword or file."""


class FileError(Error, OSError):
    """A file that cannot be read or written (an ``OSError``)."""


class MissingFileError(FileError, FileNotFoundError):
    """A named input file that does not exist (a ``FileNotFoundError``)."""


for _c in (Error, InputError, FileError, MissingFileError):
    # Shown as reflect.InputError (where users import them from), not reflect._errors.InputError.
    _c.__module__ = "reflect"
