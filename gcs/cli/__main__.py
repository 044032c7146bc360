"""`python -m gcs.cli`: the `gcs` program."""

from gcs.cli import entry_point

entry_point()
