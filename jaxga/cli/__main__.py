"""``python -m jaxga.cli``: the ``jaxga`` command."""

from jaxga.cli.entry import console

if __name__ == "__main__":  # pragma: no cover
    console()
