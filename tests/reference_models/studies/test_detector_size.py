"""The detector's reliable size from re-found rates per size bin (issue 43)."""

from reference_models.studies.detector_size import MIN_OBJECTS, reliable_side


def _rows(side, n, found):
    return [{"scene": "s", "class": "person", "side": side, "found": k < found} for k in range(n)]


def test_the_reliable_side_is_the_bin_below_the_first_unreliable_one_from_the_top():
    rows = _rows(30, 100, 100) + _rows(13, 100, 99) + _rows(11, 100, 97) + _rows(5, 100, 100)
    assert reliable_side(rows) == 12  # 10-12 re-finds 97 %: everything from 12 px up is reliable


def test_a_bin_with_too_few_objects_does_not_decide():
    few = MIN_OBJECTS - 1
    rows = _rows(30, 100, 100) + _rows(18, few, 0) + _rows(11, 100, 90)
    assert reliable_side(rows) == 12
    assert reliable_side(rows + _rows(18, 1, 0)) == 24  # now 20 objects, none re-found
