"""The per-frame flags: :class:`TrackFlag`, the module's int constants and
:func:`flag_names`, against the bit table of docs/tracker.md (the documented contract,
read as text) and plain integer arithmetic."""

import enum
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import vidtrack
from vidtrack.track import _flags, tracker

DOCS = Path(__file__).resolve().parents[1] / "docs" / "tracker.md"


def documented_bits():
    """{name: bit} from the rows ``| 4 | MERGED | ... |`` of docs/tracker.md."""
    rows = re.findall(r"^\| (\d+) \| ([A-Z_]+) \|", DOCS.read_text(), flags=re.M)
    return {name: int(bit) for bit, name in rows}


def test_the_documented_table_is_read():
    bits = documented_bits()
    assert len(bits) == 9 and bits["BORDER"] == 1 and bits["EXCLUDED"] == 256
    assert sorted(bits.values()) == [2 ** k for k in range(9)]


def test_the_intflag_s_members_are_the_documented_bits_and_the_constants():
    from vidtrack.track import TrackFlag

    assert vidtrack.TrackFlag is TrackFlag and issubclass(TrackFlag, enum.IntFlag)
    assert {f.name: f.value for f in TrackFlag} == documented_bits()
    for name, bit in documented_bits().items():
        member = TrackFlag[name]
        for module in (_flags, tracker):           # the constants the code uses, unchanged
            constant = getattr(module, name)
            assert type(constant) is int and constant == member == bit
    assert tracker.FLAGS == {bit: name.lower() for name, bit in documented_bits().items()}


def test_a_column_masks_as_the_int_it_is():
    from vidtrack.track import TrackFlag

    column = pd.Series([0, 8, 12, 36, 256], dtype=np.int32)
    masked = column & TrackFlag.LOST
    assert masked.tolist() == [0, 8, 8, 0, 0]
    assert (column & tracker.LOST).tolist() == masked.tolist()
    assert (column & tracker.LOST).dtype == np.int32    # the constants keep an int32 column


def test_flag_names_spell_each_value_s_bits_in_order():
    from vidtrack.track import flag_names

    assert vidtrack.flag_names is flag_names
    bits = sorted(documented_bits().items(), key=lambda kv: kv[1])
    values = [0, 1, 12, 36, 2 ** 9 - 1, 8 | 512, 36]
    want = []
    for v in values:                       # the bits set, by plain integer arithmetic
        names = [name for name, bit in bits if v & bit]
        if v & ~(2 ** 9 - 1):
            names.append(str(v & ~(2 ** 9 - 1)))
        want.append("|".join(names))
    assert want[2] == "MERGED|LOST" and want[5] == "LOST|512"
    assert flag_names(values) == want
    assert flag_names(np.array(values, dtype=np.int32)) == want
    assert flag_names(pd.Series(values, dtype=np.int32)) == want
    assert flag_names(pd.Series(values, dtype=np.float64)) == want   # as read with gaps
    assert flag_names([]) == []


@pytest.mark.parametrize("bad", [-1, 2.5, float("nan"), "12", None, [1]], ids=repr)
def test_flag_names_refuses_what_is_not_a_flags_value(bad):
    with pytest.raises(ValueError, match="whole number >= 0"):
        vidtrack.flag_names([4, bad])
