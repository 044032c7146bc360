"""Errors that reach the user as one clear line and a non-zero exit."""


class UserError(Exception):
    """Bad input from the user (arguments, files, traffic): printed as one line, exit code 2."""

    exit_code = 2
