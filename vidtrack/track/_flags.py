"""The per-frame flags of a track (bit values; the table is in
:mod:`vidtrack.track.tracker`, which exports them).

Internal to :mod:`vidtrack.track`.
"""

BORDER = 1
BLADE = 2
MERGED = 4
LOST = 8
PREDICTED = 16
PRE_RELEASE = 32
OUTLIER = 64
APPEARANCE = 128
EXCLUDED = 256

#: Flag names by bit value.
FLAGS = {BORDER: "border", BLADE: "blade", MERGED: "merged", LOST: "lost",
         PREDICTED: "predicted", PRE_RELEASE: "pre_release", OUTLIER: "outlier",
         APPEARANCE: "appearance", EXCLUDED: "excluded"}
