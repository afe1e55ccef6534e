"""Frames from a camera device, a video file or a folder of images (OpenCV), no ROS needed."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

__all__ = ['IMAGE_SUFFIXES', 'FrameSourceError', 'FrameSource', 'open_frames']

IMAGE_SUFFIXES = ('.jpg', '.jpeg', '.png', '.bmp', '.pgm', '.ppm', '.tif', '.tiff')


class FrameSourceError(RuntimeError):
    """A frame source cannot be opened or read; the message says why."""


@dataclass
class FrameSource:
    """An opened source of BGR frames.

    Attributes:
        name: What was opened (device, file or folder).
        fps: Nominal frame rate, Hz (the video's own, or 30 for folders and unknown rates).
        capture: The OpenCV capture for devices and videos, None for folders.
        files: The sorted image files of a folder, empty otherwise.
        announced: Frames a video file's header announces; 0 for devices and folders.
        read: Frames read from the capture so far.
    """

    name: str
    fps: float
    capture: cv2.VideoCapture | None = None
    files: tuple[Path, ...] = ()
    announced: int = 0
    read: int = 0

    @property
    def length(self) -> int | None:
        """Frames expected: a folder's images, a video's announced count; None for a device."""
        return len(self.files) if self.capture is None else self.announced or None

    @property
    def truncated(self) -> bool:
        """Whether a video ended before the frames its header announces (read to its end)."""
        return self.capture is not None and 0 < self.read < self.announced

    def __iter__(self) -> Iterator[np.ndarray | None]:
        """The frames in order, ``(H, W, 3) uint8`` BGR; None for a folder image that cannot be read."""
        if self.capture is not None:
            while True:
                ok, image = self.capture.read()
                if not ok:
                    return
                self.read += 1
                yield image if image.ndim == 3 else cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        for path in self.files:
            # One unreadable file must not end the sequence: the caller counts it.
            yield cv2.imread(str(path), cv2.IMREAD_COLOR)

    def close(self) -> None:
        """Release the device or file."""
        if self.capture is not None:
            self.capture.release()


def open_frames(source: str | Path) -> FrameSource:
    """Open ``source``: a device index (``0``) or path (``/dev/video0``), a video file, or a folder.

    A folder's images are its files with an image suffix, sorted by name (an ``img/``
    subfolder is used when the folder itself holds none, as in tracking benchmarks).

    Raises:
        FrameSourceError: Nothing usable at ``source``.
    """
    text = str(source)
    path = Path(text)
    if path.is_dir():
        folder = path / 'img' if not _images_in(path) and (path / 'img').is_dir() else path
        files = _images_in(folder)
        if not files:
            raise FrameSourceError(f'no images ({", ".join(IMAGE_SUFFIXES)}) in folder {folder}')
        return FrameSource(str(folder), 30.0, files=files)
    if text.isdigit() or text.startswith('/dev/video'):
        capture = cv2.VideoCapture(int(text) if text.isdigit() else text)
    elif path.is_file():
        capture = cv2.VideoCapture(text)
    else:
        raise FrameSourceError(f'{text} is neither a camera device, a video file nor a folder of images')
    if not capture.isOpened():
        raise FrameSourceError(f'cannot open {text}')
    fps = capture.get(cv2.CAP_PROP_FPS)
    announced = int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) if path.is_file() else 0
    return FrameSource(text, fps if 0 < fps < 1000 else 30.0, capture=capture, announced=max(announced, 0))


def _images_in(folder: Path) -> tuple[Path, ...]:
    return tuple(sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES))
