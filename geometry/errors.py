"""The one exception type for problems a user can fix, and the warning on an implausible value."""


class FecheckError(Exception):
    """A user-facing problem: bad input, an unreadable file, an impossible request.

    The message says what was wrong and what to change; the CLI prints it on one line
    and exits non-zero. `geometry` defines it so that both packages share one type
    (`fecheck.errors` re-exports it).
    """


class ImplausibleInput(UserWarning):
    """A value outside the range of a knee model: most often a unit typed wrong."""
