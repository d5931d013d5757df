"""``python -m posfb.analysis.cli``: the ``posfb`` command."""

from posfb.analysis.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
