"""The `resus` command line: thin, it parses flags into the library's settings and prints
one-line errors.

- `app`: the typer app, `main()` (the console script; `python -m resus` runs it too) and the
  handling of usage errors, interrupts and `ResusError`s.
- `parsers`: the comma-list, range and choice parsers every command shares, and the mapping
  of a library error about a setting to the flag that set it.
- one module per command: `demo`, `simulate`, `sweep`, `reconstruct`, `reslice`, `train`,
  `plan`, `scan`, `emulate`, `view`, `vessels`, `experiment`, `calibrate_time`.
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
app: main
""",
)
