"""jaxga's version, below every layer: the package's ``__version__``, and what a saved
result records as the jaxga that computed it. ``pyproject.toml`` states it too; a test
keeps the two equal."""

VERSION = "0.1.0"
