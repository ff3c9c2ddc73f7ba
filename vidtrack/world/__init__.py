"""From views to the world: the orthogonal front/top merge -> a ``WorldTrack`` in metres."""
