"""sensor_msgs/Image and CompressedImage to and from ndarrays (what cv_bridge does).

Decoding lives in :mod:`human_tracker.io.images` (no ROS needed) and is re-exported here;
this module adds the encoders that build rclpy messages.
"""

from __future__ import annotations

import array
from typing import Any

import cv2
import numpy as np
from sensor_msgs.msg import CompressedImage, Image

from human_tracker.io.images import (
    ENCODINGS,
    MAX_PIXELS,
    ImageConversionError,
    compressed_to_array,
    image_to_array,
    message_to_bgr8,
    to_bgr8,
    to_mono8,
)

__all__ = [
    'ENCODINGS',
    'MAX_PIXELS',
    'ImageConversionError',
    'image_to_array',
    'array_to_image',
    'compressed_to_array',
    'array_to_compressed',
    'to_bgr8',
    'to_mono8',
    'message_to_bgr8',
]


def array_to_image(array_: np.ndarray, encoding: str, header: Any | None = None) -> Image:
    """Encode an array as a sensor_msgs/Image (little-endian, rows packed).

    Args:
        array_: ``(H, W)`` or ``(H, W, C)`` matching ``encoding``'s layout.
        encoding: One of :data:`ENCODINGS`.
        header: std_msgs/Header to copy (stamp and frame_id), or None.

    Raises:
        ImageConversionError: The array does not fit the encoding.
    """
    layout = ENCODINGS.get(encoding)
    if layout is None:
        raise ImageConversionError(f'unsupported encoding {encoding!r}')
    expected_ndim = 2 if layout.channels == 1 else 3
    if array_.ndim != expected_ndim or (expected_ndim == 3 and array_.shape[2] != layout.channels):
        raise ImageConversionError(f'array of shape {array_.shape} does not fit {encoding}')
    pixels = np.ascontiguousarray(array_, dtype=np.dtype(layout.dtype).newbyteorder('<'))
    msg = Image()
    if header is not None:
        msg.header = header
    msg.height, msg.width = int(array_.shape[0]), int(array_.shape[1])
    msg.encoding = encoding
    msg.is_bigendian = 0
    msg.step = int(pixels.strides[0])
    msg.data = array.array('B', pixels.tobytes())
    return msg


def array_to_compressed(
    array_: np.ndarray,
    image_format: str = 'jpeg',
    header: Any | None = None,
    quality: int = 90,
) -> CompressedImage:
    """Encode a BGR or mono8 array as a sensor_msgs/CompressedImage (``jpeg`` or ``png``)."""
    extension = {'jpeg': '.jpg', 'jpg': '.jpg', 'png': '.png'}.get(image_format)
    if extension is None:
        raise ImageConversionError(f'unsupported compressed format {image_format!r} (jpeg or png)')
    params = [cv2.IMWRITE_JPEG_QUALITY, int(quality)] if extension == '.jpg' else []
    ok, encoded = cv2.imencode(extension, array_, params)
    if not ok:
        raise ImageConversionError(f'cannot encode array of shape {array_.shape} as {image_format}')
    msg = CompressedImage()
    if header is not None:
        msg.header = header
    kind = 'bgr8' if array_.ndim == 3 else 'mono8'
    msg.format = f'{kind}; {"jpeg" if extension == ".jpg" else "png"} compressed {kind}'
    msg.data = array.array('B', encoded.tobytes())
    return msg
