"""The one exception type for mistakes a user can fix (bad input, bad override, missing path).

Any layer raises `UserError` with a one-line message that names what is wrong, where (file and
line, or config key) and how to fix it. The entry point prints that line alone and exits non-zero
(a traceback only on request), so the user never digs the reason out of a stack trace. Programming
errors stay ordinary exceptions and keep their tracebacks.
"""


class UserError(ValueError):
    """A problem in the user's input or config; its message is the whole report (one line)."""
