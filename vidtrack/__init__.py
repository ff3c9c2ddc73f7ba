"""vidtrack: high-speed footage of a thrown straw to k1..k4 and the published ANOVA.

The package that touches footage and the user; the only one that imports the other
two (``fits`` for numbers, ``calibration`` for pixels to metres).
"""

__version__ = "0.1.0"

from vidtrack.errors import VidtrackError  # noqa: E402

__all__ = ["VidtrackError", "__version__"]
