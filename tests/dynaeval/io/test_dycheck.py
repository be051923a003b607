"""DyCheck's ground-truth layout: the predictions of one split paired with that split only."""

from __future__ import annotations

import pytest

from dynaeval.errors import InputError
from dynaeval.io.dycheck import dycheck_splits, pair_dycheck
from tests.dynaeval.mask_layouts import dycheck_dataset

pytest.importorskip("skimage")


def test_splits_read_from_the_dataset(tmp_path):
    pred, gt = dycheck_dataset(tmp_path)
    splits = dycheck_splits(gt)
    assert splits == {"train": {"0_00000", "0_00001", "0_00002"},
                      "val": {"1_00000", "1_00001", "1_00002"}}
    assert dycheck_splits(pred) == {}  # not rgb/<factor>x
    (gt.parent.parent / "splits" / "broken.json").write_text("{not json")
    assert set(dycheck_splits(gt)) == {"train", "val"}  # an unreadable split is ignored


def test_pairing_one_split(tmp_path):
    pred, gt = dycheck_dataset(tmp_path)
    pairing = pair_dycheck(pred, gt)
    assert [p.frame for p in pairing.pairs] == ["1_00000", "1_00001", "1_00002"]
    assert pairing.skipped == []
    assert pair_dycheck(pred, pred) is None  # no DyCheck ground truth: ordinary rules
    (gt.parent.parent / "splits" / "val.json").write_text('{"frame_names": ["1_00000"]}')
    assert pair_dycheck(pred, gt) is None  # the predictions fit no split


def test_missing_frame_of_the_split(tmp_path):
    pred, gt = dycheck_dataset(tmp_path)
    (pred / "1_00002.png").unlink()
    with pytest.raises(InputError, match=r"DyCheck split 'val': 1 of its frames have no prediction: 1_00002"):
        pair_dycheck(pred, gt)
    pairing = pair_dycheck(pred, gt, allow_missing=True)
    assert pairing.skipped == [{"camera": ".", "frame": "1_00002"}]
