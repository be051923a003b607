"""The protocol interface (issue 31): one class per protocol, registered once, and a protocol
written outside dynaeval's modules drives the registry's whole-frame metrics by its methods."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from dynaeval.errors import InputError
from dynaeval.metrics.multiscale import ms_ssim
from dynaeval.metrics.pixel import build_psnr, psnr
from dynaeval.metrics.protocol_base import Protocol
from dynaeval.metrics.protocols import PROTOCOL_NAMES, PROTOCOLS, get_protocol
from dynaeval.metrics.registry import FrameContext, build_frame_metrics, region_argument
from dynaeval.metrics.structural import build_ssim, ssim


class _Toy(Protocol):
    """A protocol of the test's own: PSNR of the mean absolute error, SSIM of the squared
    images, and the mask multiplied into both images (as NeRFBaselines)."""

    name = "toy"
    reference = "this test"

    def psnr_of(self, pred, gt, data_range):
        return -10.0 * math.log10(float(np.mean(np.abs(pred - gt))))

    def ssim_of(self, pred, gt, data_range):
        return ssim(pred**2, gt**2, data_range=data_range)

    def weighs_whole_frame(self):
        return True

    def apply_masks(self, pred, gt, weights):
        if weights is None:
            return pred, gt
        w = np.asarray(weights)[..., None]
        return pred * w, gt * w


@pytest.fixture
def pair(rng):
    gt = rng.random((48, 40, 3))
    return np.clip(gt + rng.normal(0, 0.05, gt.shape), 0, 1), gt


def test_each_protocol_is_its_own_class_in_one_registry():
    """Every ``--protocol`` choice is the name of one registered instance of its own subclass
    of ``Protocol``; the choices are the registry's keys."""
    assert PROTOCOL_NAMES == tuple(PROTOCOLS)
    classes = {type(get_protocol(n)) for n in PROTOCOL_NAMES}
    assert len(classes) == len(PROTOCOL_NAMES)
    for name in PROTOCOL_NAMES:
        proto = get_protocol(name)
        assert isinstance(proto, Protocol) and type(proto) is not Protocol
        assert proto.name == name and proto.describe()["name"] == name
    with pytest.raises(InputError, match="protocol must be one of dynaeval, nerfbaselines"):
        get_protocol("toy")


def test_a_protocol_class_drives_the_registry_whole_frame_metrics(pair, rng):
    """A subclass overriding ``psnr_of``/``ssim_of``/``apply_masks`` is what ``psnr``/``ssim``
    compute over the whole frame (and with a given mask); regions stay dynaeval's."""
    pred, gt = pair
    ctx = FrameContext(protocol=_Toy())
    fpsnr, fssim = build_psnr(ctx), build_ssim(ctx)
    assert fpsnr(pred, gt, {}) == pytest.approx(-10 * np.log10(np.mean(np.abs(pred - gt))), abs=1e-12)
    assert fssim(pred, gt, {}) == pytest.approx(ssim(pred**2, gt**2), abs=1e-12)
    assert fssim(pred, gt, {}) != pytest.approx(ssim(pred, gt), abs=1e-4)
    boxes = np.array([[4, 6, 30, 40]])
    assert fpsnr(pred, gt, {"boxes": boxes}) == psnr(pred, gt, boxes=boxes)
    w = (rng.random(gt.shape[:2]) > 0.5).astype(np.float64)
    masked = -10 * np.log10(np.mean(np.abs(pred - gt) * w[..., None]))
    assert fpsnr(pred, gt, {"weights": w}) == pytest.approx(masked, abs=1e-12)


def test_region_argument_passes_weights_to_a_protocol_that_weighs_the_whole_frame():
    class Frame:
        boxes, mask, weights = None, None, np.ones((4, 4))

    assert region_argument("whole", "psnr", _Toy(), Frame())["weights"] is Frame.weights
    assert region_argument("whole", "psnr", get_protocol("dynaeval"), Frame()) == {}
    assert region_argument("whole", "psnr", get_protocol("nerfbaselines"), Frame()) != {}


def test_the_base_class_is_dynaevals_behaviour(pair):
    """What a protocol does not override is dynaeval's: float64 PSNR, its SSIM, torchmetrics'
    MS-SSIM, no 8-bit step, a mask refused over the whole frame."""
    pred, gt = pair
    base = Protocol()
    assert base.whole_psnr(pred, gt) == psnr(pred, gt)
    assert base.whole_ssim(pred, gt) == ssim(pred, gt)
    big = np.tile(gt, (4, 5, 1))
    assert base.whole_msssim(big, big * 0.9) == ms_ssim(big, big * 0.9)
    assert base.prepare_images(pred, gt) == (pred, gt)
    with pytest.raises(InputError, match="does not score the whole frame with a mask"):
        base.whole_psnr(pred, gt, weights=np.ones(gt.shape[:2]))


@pytest.mark.parametrize("name", PROTOCOL_NAMES)
def test_protocols_are_constant_and_survive_pickling(name):
    """A run's plan (with its protocol) crosses process pools: equal after a pickle round trip;
    nothing may change a registered protocol."""
    proto = get_protocol(name)
    back = pickle.loads(pickle.dumps(proto))
    assert back == proto and hash(back) == hash(proto) and back.describe() == proto.describe()
    assert all(back != get_protocol(other) for other in PROTOCOL_NAMES if other != name)
    with pytest.raises(AttributeError, match="constant"):
        proto.clip = True


def test_what_each_protocol_does_with_masks_and_clipping():
    """The methods that replaced the ``masks``/``clip``/``quantize`` reads outside the classes."""
    uses = {n for n in PROTOCOL_NAMES if get_protocol(n).uses_masks()}
    assert uses == {"nerfbaselines", "dycheck"}
    assert [n for n in PROTOCOL_NAMES if get_protocol(n).weighs_whole_frame()] == ["nerfbaselines"]
    assert {n: get_protocol(n).mask_regions() for n in PROTOCOL_NAMES if get_protocol(n).mask_regions()} \
        == {"dycheck": ("covisible",)}
    assert {n for n in PROTOCOL_NAMES if get_protocol(n).clips_images()} == {
        "nerfbaselines", "kplanes", "dycheck"}
    ctx = FrameContext(protocol=get_protocol("dycheck"))
    built = build_frame_metrics(ctx, ("psnr",), ("whole", *get_protocol("dycheck").mask_regions()))
    assert sorted(built.fns) == ["mpsnr", "psnr"]
