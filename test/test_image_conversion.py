"""Image / CompressedImage <-> ndarray for every listed encoding, step and endianness."""

from __future__ import annotations

import array

import cv2
import numpy as np
import pytest
from sensor_msgs.msg import CompressedImage, Image

from human_tracker.ros.image_conversion import (
    ENCODINGS,
    ImageConversionError,
    array_to_compressed,
    array_to_image,
    compressed_to_array,
    image_to_array,
    message_to_bgr8,
)

RNG = np.random.default_rng(0)


def _array_for(encoding: str, height: int = 6, width: int = 8) -> np.ndarray:
    layout = ENCODINGS[encoding]
    shape = (height, width) if layout.channels == 1 else (height, width, layout.channels)
    if layout.dtype == 'f4':
        return RNG.normal(size=shape).astype(np.float32)
    return RNG.integers(0, np.iinfo(np.dtype(layout.dtype)).max, size=shape, dtype=np.dtype(layout.dtype))


@pytest.mark.parametrize('encoding', sorted(ENCODINGS))
def test_round_trip_every_encoding(encoding: str) -> None:
    original = _array_for(encoding)
    msg = array_to_image(original, encoding)
    assert msg.encoding == encoding and msg.step == original.strides[0]
    np.testing.assert_array_equal(image_to_array(msg), original)


@pytest.mark.parametrize('encoding', sorted(e for e in ENCODINGS if e != '32FC2'))
def test_every_image_encoding_converts_to_bgr8(encoding: str) -> None:
    bgr = message_to_bgr8(array_to_image(_array_for(encoding), encoding))
    assert bgr.shape == (6, 8, 3) and bgr.dtype == np.uint8


def test_row_padding_in_step_is_skipped() -> None:
    pixels = np.arange(12, dtype=np.uint8).reshape(3, 4)
    padded = np.zeros((3, 7), dtype=np.uint8)
    padded[:, :4] = pixels
    msg = Image(height=3, width=4, encoding='mono8', step=7, data=array.array('B', padded.tobytes()))
    np.testing.assert_array_equal(image_to_array(msg), pixels)


def test_big_endian_mono16() -> None:
    pixels = np.array([[1, 256], [513, 65535]], dtype=np.uint16)
    msg = Image(
        height=2,
        width=2,
        encoding='mono16',
        is_bigendian=1,
        step=4,
        data=array.array('B', pixels.astype('>u2').tobytes()),
    )
    np.testing.assert_array_equal(image_to_array(msg), pixels)


def test_colour_orders_are_honoured() -> None:
    rgb = np.zeros((2, 2, 3), dtype=np.uint8)
    rgb[..., 0] = 255  # pure red in RGB order
    bgr = message_to_bgr8(array_to_image(rgb, 'rgb8'))
    assert bgr[0, 0].tolist() == [0, 0, 255]
    # UYVY with U = V = 128 is grey; BT.601 video range maps luma 90 to (90 - 16) * 255 / 219 = 86.
    uyvy = np.full((2, 4, 2), 128, dtype=np.uint8)
    uyvy[..., 1] = 90
    assert message_to_bgr8(array_to_image(uyvy, 'yuv422'))[0, 0].tolist() == pytest.approx([86, 86, 86], abs=1)
    # A flat Bayer mosaic demosaics to a flat image.
    flat = np.full((4, 4), 77, dtype=np.uint8)
    assert np.all(np.abs(message_to_bgr8(array_to_image(flat, 'bayer_rggb8')).astype(int) - 77) <= 1)


@pytest.mark.parametrize(
    ('fields', 'match'),
    [
        ({'encoding': 'weird9'}, 'unsupported encoding'),
        ({'width': 0}, 'zero size'),
        ({'step': 3}, 'step 3 is smaller'),
        ({'data': array.array('B', bytes(10))}, 'needs'),
        ({'data': array.array('B', bytes(200))}, 'more than height x step'),
        ({'width': 100000, 'height': 100000, 'step': 100000}, 'exceeds the limit'),
    ],
)
def test_malformed_images_raise_clear_errors(fields: dict, match: str) -> None:
    msg = Image(height=4, width=4, encoding='mono8', step=4, data=array.array('B', bytes(16)))
    for key, value in fields.items():
        setattr(msg, key, value)
    with pytest.raises(ImageConversionError, match=match):
        image_to_array(msg)


def test_compressed_round_trip_and_corrupt_data() -> None:
    image = cv2.resize(RNG.integers(0, 255, (8, 8, 3), dtype=np.uint8), (64, 48))
    png = array_to_compressed(image, 'png')
    np.testing.assert_array_equal(compressed_to_array(png), image)
    jpeg = array_to_compressed(image, 'jpeg', quality=95)
    assert np.abs(compressed_to_array(jpeg).astype(int) - image).mean() < 6
    broken = CompressedImage(format='jpeg', data=array.array('B', bytes(jpeg.data)[:20]))
    with pytest.raises(ImageConversionError, match='cannot decode'):
        compressed_to_array(broken)
    with pytest.raises(ImageConversionError, match='no data'):
        compressed_to_array(CompressedImage(format='jpeg'))
