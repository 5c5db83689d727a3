"""The exceptions of ``reflect``: one base class, :class:`Error`, and subclasses of the built-in
classes a caller already catches, so ``except ValueError`` keeps working.

- :class:`InputError` (``ValueError``): a bad argument or bad input data. The message names the
  keyword (``spp=``, ``target_rel_error=``) or the file, in this API's terms.
- :class:`FileError` (``OSError``): a file that cannot be read or written;
  :class:`MissingFileError` (also ``FileNotFoundError``) when it does not exist.

Warnings are :class:`Warning` (a ``UserWarning``), raised with :func:`warnings.warn`: a report's
``warnings`` (an ill-conditioned order, a fit that aliases, …) and a render that stopped at its spp
cap short of ``target_rel_error`` (:class:`TargetNotReachedWarning`).
"""


class Error(Exception):
    """Base class of every error ``reflect`` raises on bad input (not of ``KeyboardInterrupt``)."""


class InputError(Error, ValueError):
    """A bad argument or bad input data (a ``ValueError``); the message names the keyword or file."""


class FileError(Error, OSError):
    """A file that cannot be read or written (an ``OSError``)."""


class MissingFileError(FileError, FileNotFoundError):
    """A named input file that does not exist (a ``FileNotFoundError``)."""


class Warning(UserWarning):  # noqa: A001 (reflect.Warning, as numpy.exceptions and others name theirs)
    """A result that holds but should not be trusted blindly: each of a report's ``warnings``, raised
    when the call returns (the report keeps them in ``.warnings``)."""


class TargetNotReachedWarning(Warning):
    """A render to ``target_rel_error`` that stopped at its spp cap (or ``time_limit``) first:
    ``stats["target_reached"]`` is False; ``stats["rel_error_p95"]`` is the error reached."""


for _c in (Error, InputError, FileError, MissingFileError, Warning, TargetNotReachedWarning):
    # Shown as reflect.InputError (where users import them from), not reflect._errors.InputError.
    _c.__module__ = "reflect"
