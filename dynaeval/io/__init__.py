"""Finding, reading and pairing frames (folders of images, one folder per camera, video files)."""

from dynaeval.io.frames import (
    Camera,
    FramePair,
    FrameRef,
    Pairing,
    find_frames,
    natural_key,
    pair_frames,
)
from dynaeval.io.images import IMAGE_EXTENSIONS, composite_alpha, read_image, to_float
from dynaeval.io.video import VIDEO_EXTENSIONS

__all__ = [
    "IMAGE_EXTENSIONS",
    "VIDEO_EXTENSIONS",
    "Camera",
    "FramePair",
    "FrameRef",
    "Pairing",
    "composite_alpha",
    "find_frames",
    "natural_key",
    "pair_frames",
    "read_image",
    "to_float",
]
