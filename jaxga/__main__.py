"""``python -m jaxga``: the ``jaxga`` command, as ``python -m jaxga.cli``."""

from jaxga.cli.entry import console

if __name__ == "__main__":  # pragma: no cover
    console()
