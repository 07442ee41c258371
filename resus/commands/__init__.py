"""Command-line sub-commands, one module per pipeline stage (see `resus.cli`)."""
