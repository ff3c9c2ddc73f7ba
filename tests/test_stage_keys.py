"""The stage cache's keys: what computes a stage, not the package's version.

The behaviour on the command line (a note when a stage is reused) is the row
``fit-says-when-it-reuses-a-stage`` of tests/test_hostile_inputs.py.
"""

import vidtrack.track.tracker as tracker
from vidtrack.run import cache
from vidtrack.run.cache import FIT_ALGORITHM, stage_key, tracker_version


def test_the_key_changes_with_the_algorithm_settings_and_inputs():
    base = stage_key("fit", algorithm=FIT_ALGORITHM, settings={"model": "quadratic"},
                     inputs={"tracks": "abc"})
    assert base == stage_key("fit", algorithm=FIT_ALGORITHM,
                             settings={"model": "quadratic"}, inputs={"tracks": "abc"})
    for other in (stage_key("fit", algorithm=FIT_ALGORITHM + "x",
                            settings={"model": "quadratic"}, inputs={"tracks": "abc"}),
                  stage_key("fit", algorithm=FIT_ALGORITHM, settings={"model": "linear"},
                            inputs={"tracks": "abc"}),
                  stage_key("fit", algorithm=FIT_ALGORITHM, settings={"model": "quadratic"},
                            inputs={"tracks": "abd"}),
                  stage_key("tracks", algorithm=FIT_ALGORITHM,
                            settings={"model": "quadratic"}, inputs={"tracks": "abc"})):
        assert other != base


def test_the_tracker_source_keys_the_tracks_without_a_version_of_its_own():
    if hasattr(tracker, "ALGORITHM_VERSION"):
        return      # the tracker says its version itself (next test)
    v = tracker_version()
    assert v["algorithm"] == cache.TRACK_ALGORITHM and len(v["source"]) == 64
    assert "__version__" not in str(v)


def test_the_trackers_own_version_is_taken_when_it_has_one(monkeypatch):
    monkeypatch.setattr(tracker, "ALGORITHM_VERSION", "tracker-test-1", raising=False)
    one = tracker_version()
    monkeypatch.setattr(tracker, "ALGORITHM_VERSION", "tracker-test-2", raising=False)
    two = tracker_version()
    assert one["algorithm"] == "tracker-test-1" and two["algorithm"] == "tracker-test-2"
    assert stage_key("tracks", algorithm=one) != stage_key("tracks", algorithm=two)
