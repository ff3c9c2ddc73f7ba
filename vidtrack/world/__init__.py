"""From views to the world: the orthogonal front/top merge or the triangulation of calibrated
cameras -> a ``WorldTrack`` in metres."""
