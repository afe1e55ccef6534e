"""Decoding sensor_msgs/Image and CompressedImage into ndarrays, without ROS.

Decoding honours ``step`` (row padding) and ``is_bigendian``, checks every size against the
buffer before touching it, and refuses absurd sizes before allocating anything. Every
failure raises :class:`ImageConversionError` with a message that says what was wrong.

The functions read messages by their fields only, so rclpy messages, messages deserialised
by rosbags, or any object with the same fields work.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

__all__ = [
    'ENCODINGS',
    'MAX_PIXELS',
    'ImageConversionError',
    'image_to_array',
    'compressed_to_array',
    'to_bgr8',
    'to_mono8',
    'message_to_bgr8',
    'stamp_ns',
]

MAX_PIXELS = 8192 * 8192
"""Largest width x height accepted; larger claims are refused before any allocation."""


class ImageConversionError(ValueError):
    """An image message cannot be converted; the message says why."""


@dataclass(frozen=True)
class _Layout:
    dtype: str
    channels: int
    to_bgr: int | None  # cv2 colour conversion code to BGR, None for already BGR / mono


_BAYER = {
    'bayer_rggb8': cv2.COLOR_BayerRGGB2BGR,
    'bayer_bggr8': cv2.COLOR_BayerBGGR2BGR,
    'bayer_gbrg8': cv2.COLOR_BayerGBRG2BGR,
    'bayer_grbg8': cv2.COLOR_BayerGRBG2BGR,
}

ENCODINGS: dict[str, _Layout] = {
    'mono8': _Layout('u1', 1, None),
    '8UC1': _Layout('u1', 1, None),
    'mono16': _Layout('u2', 1, None),
    '16UC1': _Layout('u2', 1, None),
    '32FC1': _Layout('f4', 1, None),
    '32FC2': _Layout('f4', 2, None),
    'bgr8': _Layout('u1', 3, None),
    '8UC3': _Layout('u1', 3, None),
    'rgb8': _Layout('u1', 3, cv2.COLOR_RGB2BGR),
    'bgra8': _Layout('u1', 4, cv2.COLOR_BGRA2BGR),
    'rgba8': _Layout('u1', 4, cv2.COLOR_RGBA2BGR),
    # yuv422 in ROS is UYVY; yuv422_yuy2 is YUYV. Two bytes per pixel.
    'yuv422': _Layout('u1', 2, cv2.COLOR_YUV2BGR_UYVY),
    'uyvy': _Layout('u1', 2, cv2.COLOR_YUV2BGR_UYVY),
    'yuv422_yuy2': _Layout('u1', 2, cv2.COLOR_YUV2BGR_YUY2),
    **{name: _Layout('u1', 1, code) for name, code in _BAYER.items()},
}
"""Supported ``encoding`` strings and their pixel layout."""


def _buffer(data: Any) -> np.ndarray:
    if isinstance(data, np.ndarray):
        return data.reshape(-1).view(np.uint8)
    return np.frombuffer(memoryview(data).cast('B'), dtype=np.uint8)


def image_to_array(msg: Any) -> np.ndarray:
    """Decode a sensor_msgs/Image into an array in the encoding's own channel order.

    Returns:
        ``(H, W)`` for one channel, ``(H, W, C)`` otherwise, native byte order. The
        array does not share memory with the message.

    Raises:
        ImageConversionError: Unknown encoding, bad sizes, or a buffer that does not match.
    """
    encoding = str(msg.encoding)
    layout = ENCODINGS.get(encoding)
    if layout is None:
        raise ImageConversionError(f'unsupported encoding {encoding!r}; supported: {", ".join(sorted(ENCODINGS))}')
    height, width, step = int(msg.height), int(msg.width), int(msg.step)
    if height <= 0 or width <= 0:
        raise ImageConversionError(f'image has zero size ({width}x{height})')
    if height * width > MAX_PIXELS:
        raise ImageConversionError(f'image of {width}x{height} exceeds the limit of {MAX_PIXELS} pixels')
    itemsize = np.dtype(layout.dtype).itemsize
    row_bytes = width * layout.channels * itemsize
    if step < row_bytes:
        raise ImageConversionError(f'step {step} is smaller than a row of {row_bytes} bytes ({width} px {encoding})')
    buffer = _buffer(msg.data)
    needed = step * (height - 1) + row_bytes
    if buffer.size < needed:
        raise ImageConversionError(
            f'data holds {buffer.size} bytes, {width}x{height} {encoding} with step {step} needs {needed}'
        )
    if buffer.size > step * height:
        raise ImageConversionError(f'data holds {buffer.size} bytes, more than height x step = {step * height}')
    if layout.to_bgr is not None and layout.channels == 2 and width % 2:
        raise ImageConversionError(f'{encoding} needs an even width, got {width}')
    rows = np.lib.stride_tricks.as_strided(buffer, shape=(height, row_bytes), strides=(step, 1))
    byteorder = '>' if msg.is_bigendian else '<'
    pixels = np.ascontiguousarray(rows).view(np.dtype(layout.dtype).newbyteorder(byteorder))
    pixels = pixels.astype(np.dtype(layout.dtype).newbyteorder('='), copy=False)
    shape = (height, width) if layout.channels == 1 else (height, width, layout.channels)
    return pixels.reshape(shape)


def compressed_to_array(msg: Any) -> np.ndarray:
    """Decode a sensor_msgs/CompressedImage (JPEG, PNG, ...) into a BGR or mono array.

    Raises:
        ImageConversionError: Empty or undecodable data.
    """
    buffer = _buffer(msg.data)
    if buffer.size == 0:
        raise ImageConversionError(f'compressed image ({msg.format!r}) has no data')
    image = cv2.imdecode(buffer, cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ImageConversionError(f'cannot decode compressed image of {buffer.size} bytes, format {msg.format!r}')
    if image.shape[0] * image.shape[1] > MAX_PIXELS:
        raise ImageConversionError(f'decoded image of {image.shape[1]}x{image.shape[0]} exceeds {MAX_PIXELS} pixels')
    return image


def _to_8bit(values: np.ndarray) -> np.ndarray:
    """Scale 16-bit or float intensities to 0-255 (floats by their finite range)."""
    if values.dtype == np.uint16:
        return (values >> 8).astype(np.uint8)
    finite = np.isfinite(values)
    if not finite.any():
        raise ImageConversionError('float image has no finite value')
    lo, hi = float(values[finite].min()), float(values[finite].max())
    scaled = np.zeros(values.shape, dtype=np.float64)
    if hi > lo:
        # float64: a float32 range can span ±3e38, whose difference overflows float32.
        scaled[finite] = (values[finite].astype(np.float64) - lo) * (255.0 / (hi - lo))
    return np.clip(scaled, 0.0, 255.0).astype(np.uint8)


def to_bgr8(pixels: np.ndarray, encoding: str) -> np.ndarray:
    """Convert a decoded array in ``encoding`` to ``(H, W, 3) uint8`` BGR."""
    layout = ENCODINGS[encoding]
    if layout.channels == 2 and layout.to_bgr is None:
        raise ImageConversionError(f'{encoding} is not an intensity or colour image')
    if pixels.dtype != np.uint8:
        pixels = _to_8bit(pixels)
    if layout.to_bgr is not None:
        return cv2.cvtColor(pixels, layout.to_bgr)
    if pixels.ndim == 2:
        return cv2.cvtColor(pixels, cv2.COLOR_GRAY2BGR)
    return pixels


def to_mono8(image_bgr: np.ndarray) -> np.ndarray:
    """``(H, W) uint8`` intensity of a BGR (or already mono) image."""
    if image_bgr.ndim == 2:
        return image_bgr
    return cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY)


def message_to_bgr8(msg: Any) -> np.ndarray:
    """Any Image or CompressedImage message to ``(H, W, 3) uint8`` BGR."""
    if hasattr(msg, 'format') and not hasattr(msg, 'encoding'):
        image = compressed_to_array(msg)
        if image.dtype != np.uint8:
            image = _to_8bit(image)
        if image.ndim == 2:
            return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        if image.shape[2] == 4:
            return cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
        return image
    return to_bgr8(image_to_array(msg), str(msg.encoding))


def stamp_ns(header: Any) -> int:
    """A std_msgs/Header's stamp in nanoseconds (rclpy or rosbags message alike)."""
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)
