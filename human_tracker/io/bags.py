"""rosbag2 bags in and out (sqlite3 and mcap) through the ``rosbags`` library, no ROS needed.

Camera topics hold ``sensor_msgs/msg/Image`` or ``CompressedImage``; ground truth is
``geometry_msgs/msg/PolygonStamped`` on ``/ground_truth/<target>`` (the target's box as four
corners, or no points where the target is out of view).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import cv2
import numpy as np
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.rosbag2 import ReaderError, StoragePlugin, Writer

from human_tracker.io.bag_readers import TYPESTORE, BagError, BareMcapReader, CutMcapReader, open_bag
from human_tracker.io.images import stamp_ns
from human_tracker.scenes.generator import SceneSpec, render_scene
from human_tracker.vision.geometry.camera import default_camera_matrix

_LOG = logging.getLogger(__name__)

__all__ = [
    'BagError',
    'BagFrame',
    'BareMcapReader',
    'CutMcapReader',
    'open_bag',
    'CAMERA_TOPIC',
    'COMPRESSED_CAMERA_TOPIC',
    'CAMERA_INFO_TOPIC',
    'DEPTH_TOPIC',
    'ground_truth_topic',
    'guarded',
    'write_bag',
    'write_scene_bag',
    'read_frames',
]

CAMERA_TOPIC = '/camera/image_raw'
COMPRESSED_CAMERA_TOPIC = '/camera/image_raw/compressed'
CAMERA_INFO_TOPIC = '/camera/camera_info'
DEPTH_TOPIC = '/camera/depth/image_raw'
CAMERA_FRAME = 'camera_optical_frame'
_IMAGE_TYPES = ('sensor_msgs/msg/Image', 'sensor_msgs/msg/CompressedImage')

Box = tuple[float, float, float, float]
T = TypeVar('T')


def guarded(items: Iterable[T], path: Path) -> Iterator[T]:
    """Iterate over what a bag reader yields, turning any error it raises into a BagError.

    A corrupted file can make the reader fail in arbitrary ways (struct, overflow, key or
    decompression errors); only the reader's own ``next`` is guarded, never the consumer.
    """
    iterator = iter(items)
    while True:
        try:
            item = next(iterator)
        except StopIteration:
            return
        except Exception as err:
            raise BagError(f'{path}: corrupt or unreadable bag ({type(err).__name__}: {err})') from err
        yield item


def ground_truth_topic(target: str) -> str:
    """Topic of the ground-truth outline of ``target`` (``head``, ``hand``, or one of several
    tracks: ``person_1/head``, ``person_2/hand``, ...)."""
    return f'/ground_truth/{target}'


def _header(stamp_ns: int) -> object:
    types = TYPESTORE.types
    stamp = types['builtin_interfaces/msg/Time'](sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)
    return types['std_msgs/msg/Header'](stamp=stamp, frame_id=CAMERA_FRAME)


def _camera_info(width: int, height: int, stamp_ns: int) -> object:
    k = default_camera_matrix(width, height)
    projection = np.hstack([k, np.zeros((3, 1))])
    return TYPESTORE.types['sensor_msgs/msg/CameraInfo'](
        header=_header(stamp_ns),
        height=height,
        width=width,
        distortion_model='plumb_bob',
        d=np.zeros(5),
        k=k.reshape(-1),
        r=np.eye(3).reshape(-1),
        p=projection.reshape(-1),
        binning_x=0,
        binning_y=0,
        roi=TYPESTORE.types['sensor_msgs/msg/RegionOfInterest'](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
        ),
    )


def _polygon(stamp_ns: int, box: tuple[float, float, float, float] | None) -> object:
    types = TYPESTORE.types
    point = types['geometry_msgs/msg/Point32']
    corners = []
    if box is not None:
        x, y, w, h = box
        corners = [
            point(x=x, y=y, z=0.0),
            point(x=x + w, y=y, z=0.0),
            point(x=x + w, y=y + h, z=0.0),
            point(x=x, y=y + h, z=0.0),
        ]
    return types['geometry_msgs/msg/PolygonStamped'](
        header=_header(stamp_ns), polygon=types['geometry_msgs/msg/Polygon'](points=corners)
    )


def _raw_image(header: object, pixels: np.ndarray, encoding: str) -> object:
    """A rosbags ``sensor_msgs/Image`` of ``pixels`` (``(H, W)`` or ``(H, W, C)``, little-endian) under ``encoding``."""
    pixels = np.ascontiguousarray(pixels)
    return TYPESTORE.types['sensor_msgs/msg/Image'](
        header=header,
        height=pixels.shape[0],
        width=pixels.shape[1],
        encoding=encoding,
        is_bigendian=0,
        step=pixels.strides[0],
        data=pixels.reshape(-1).view(np.uint8),
    )


def write_bag(
    path: str | Path,
    frames: Iterable[tuple[int, np.ndarray, Box | None | Mapping[str, Box | None]]],
    *,
    compressed: bool = True,
    storage: str = 'mcap',
    jpeg_quality: int = 65,
    target: str = 'head',
) -> Path:
    """Record frames with their ground truth as a rosbag2 bag.

    Args:
        path: Bag folder to create (must not exist).
        frames: ``(stamp_ns, (H, W, 3) uint8 BGR image, truth)`` in time order, ``truth`` a box
            or None (of ``target``), or several tracks' boxes by name (each on its own topic,
            :func:`ground_truth_topic`); each with a fourth item, its registered ``(H, W)
            uint16`` depth image in millimetres (``16UC1`` on :data:`DEPTH_TOPIC`), when the bag
            is an RGB-D camera's.
        compressed: Record JPEG ``CompressedImage`` on :data:`COMPRESSED_CAMERA_TOPIC`
            (small bags) instead of raw bgr8 ``Image`` on :data:`CAMERA_TOPIC`.
        storage: ``mcap`` or ``sqlite3``.
        jpeg_quality: JPEG quality 0-100 for compressed frames.
        target: Ground-truth topic suffix.

    Returns:
        The bag's path.
    """
    path = Path(path)
    plugin = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}[storage]
    types = TYPESTORE.types
    image_type = 'sensor_msgs/msg/CompressedImage' if compressed else 'sensor_msgs/msg/Image'
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        camera = writer.add_connection(
            COMPRESSED_CAMERA_TOPIC if compressed else CAMERA_TOPIC, image_type, typestore=TYPESTORE
        )
        info = writer.add_connection(CAMERA_INFO_TOPIC, 'sensor_msgs/msg/CameraInfo', typestore=TYPESTORE)
        truths: dict[str, object] = {}
        depth_connection = None
        for stamp_ns, image, truth, *depth in frames:
            boxes = truth if isinstance(truth, Mapping) else {target: truth}
            for name in boxes:
                if name not in truths:
                    truths[name] = writer.add_connection(
                        ground_truth_topic(name), 'geometry_msgs/msg/PolygonStamped', typestore=TYPESTORE
                    )
            header = _header(stamp_ns)
            if depth:
                if depth_connection is None:
                    depth_connection = writer.add_connection(DEPTH_TOPIC, 'sensor_msgs/msg/Image', typestore=TYPESTORE)
                depth_msg = _raw_image(header, np.asarray(depth[0], dtype=np.uint16), '16UC1')
                writer.write(depth_connection, stamp_ns, TYPESTORE.serialize_cdr(depth_msg, 'sensor_msgs/msg/Image'))
            height, width = image.shape[:2]
            if compressed:
                ok, encoded = cv2.imencode('.jpg', image, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
                if not ok:
                    raise BagError(f'cannot JPEG-encode a frame of shape {image.shape}')
                msg = types['sensor_msgs/msg/CompressedImage'](
                    header=header, format='bgr8; jpeg compressed bgr8', data=encoded.reshape(-1)
                )
            else:
                msg = _raw_image(header, image, 'bgr8')
            writer.write(camera, stamp_ns, TYPESTORE.serialize_cdr(msg, image_type))
            writer.write(
                info,
                stamp_ns,
                TYPESTORE.serialize_cdr(_camera_info(width, height, stamp_ns), 'sensor_msgs/msg/CameraInfo'),
            )
            for name, box in boxes.items():
                polygon = TYPESTORE.serialize_cdr(_polygon(stamp_ns, box), 'geometry_msgs/msg/PolygonStamped')
                writer.write(truths[name], stamp_ns, polygon)
    return path


def write_scene_bag(spec: SceneSpec, path: str | Path, **options: object) -> Path:
    """Render ``spec`` and record it with :func:`write_bag` (same options)."""
    several = spec.target == 'people'
    frames = (
        (f.stamp_ns, f.image, f.targets if several else f.box, *([] if f.depth is None else [f.depth]))
        for f in render_scene(spec)
    )
    return write_bag(path, frames, target=spec.target, **options)  # type: ignore[arg-type]


@dataclass
class BagFrame:
    """A camera frame read from a bag.

    Attributes:
        index: Frame index from 0 in the bag.
        stamp_ns: Header stamp, nanoseconds.
        message: The deserialised image message (rosbags types: fields as in ROS).
        ground_truth: ``(x, y, w, h)`` box of the target at this stamp, None when the target
            is not annotated or out of view, or when the bag has no ground truth.
        ground_truths: The box of every ground-truth track read (the ``target`` asked for, else
            all) by name (``head``; ``person_1/head``, ``person_1/hand``, ...);
            ``ground_truth`` is the first's.
    """

    index: int
    stamp_ns: int
    message: object
    ground_truth: tuple[float, float, float, float] | None
    ground_truths: dict[str, tuple[float, float, float, float] | None] = field(default_factory=dict)


def _deserialize(reader: AnyReader | BareMcapReader, raw: bytes, msgtype: str, path: Path) -> object:
    try:
        return reader.deserialize(raw, msgtype)
    except Exception as err:
        raise BagError(f'{path}: a {msgtype} message cannot be decoded ({type(err).__name__}: {err})') from err


def ground_truth_target(path: str | Path) -> str | None:
    """What a bag's ground truth outlines (``head``, ``hand``: its ``/ground_truth/<target>``
    topic; ``person``: several tracks, ``/ground_truth/person_1/head`` and others), or None.

    Raises:
        BagError: The bag is missing or unreadable.
    """
    path = Path(path)
    prefix = ground_truth_topic('')
    try:
        with open_bag(path) as reader:
            topics = sorted(c.topic for c in reader.connections if c.topic.startswith(prefix))
    except (AnyReaderError, ReaderError, OSError) as err:
        raise BagError(f'cannot read bag {path}: {err}') from err
    if any('/' in topic[len(prefix) :] for topic in topics):
        return 'person'
    return topics[0][len(prefix) :] if topics else None


def camera_frame_count(path: str | Path) -> int | None:
    """How many frames the bag's first camera topic holds (as :func:`read_frames` reads it), or
    None where the bag's index does not say.

    Raises:
        BagError: The bag is missing or unreadable.
    """
    path = Path(path)
    try:
        with open_bag(path) as reader:
            counts = [getattr(c, 'msgcount', 0) for c in reader.connections if c.msgtype in _IMAGE_TYPES]
    except (AnyReaderError, ReaderError, OSError) as err:
        raise BagError(f'cannot read bag {path}: {err}') from err
    return counts[0] if counts and counts[0] > 0 else None


def read_frames(
    path: str | Path,
    *,
    camera_topic: str | None = None,
    target: str | None = None,
    warn: Callable[[str], None] | None = None,
) -> Iterator[BagFrame]:
    """Iterate over the camera frames of a bag with their ground truth matched by stamp.

    Args:
        path: Bag folder, or a single ``.mcap`` / ``.db3`` file.
        camera_topic: Topic to read; by default the first Image or CompressedImage topic.
        target: Which ``/ground_truth/<target>`` topic to match; by default the first one.
        warn: Told what was recovered of a recording cut short (:class:`CutMcapReader`);
            None: logged as a warning.

    Raises:
        BagError: The bag is missing, unreadable, or has no such camera topic.
    """
    path = Path(path)
    try:
        with open_bag(path) as reader:
            if isinstance(reader, CutMcapReader):
                (warn or _LOG.warning)(reader.note)
            cameras = [
                c
                for c in reader.connections
                if c.msgtype in _IMAGE_TYPES and (camera_topic is None or c.topic == camera_topic)
            ]
            if not cameras:
                found = ', '.join(sorted(f'{c.topic} ({c.msgtype})' for c in reader.connections)) or 'none'
                raise BagError(
                    f'{path}: no camera topic {camera_topic or "(Image or CompressedImage)"}; topics: {found}'
                )
            camera = cameras[0]
            truth_connections = [
                c
                for c in reader.connections
                if c.topic == ground_truth_topic(target)
                or (target is None and c.topic.startswith(ground_truth_topic('')))
            ]
            names = [c.topic[len(ground_truth_topic('')) :] for c in truth_connections]
            truths: dict[str, dict[int, tuple[float, float, float, float] | None]] = {name: {} for name in names}
            for conn, _, raw in guarded(reader.messages(connections=truth_connections), path):
                polygon = _deserialize(reader, raw, conn.msgtype, path)
                points = np.array([[p.x, p.y] for p in polygon.polygon.points], dtype=np.float64)
                box = None
                if len(points):
                    lo, hi = points.min(axis=0), points.max(axis=0)
                    box = (float(lo[0]), float(lo[1]), float(hi[0] - lo[0]), float(hi[1] - lo[1]))
                truths[conn.topic[len(ground_truth_topic('')) :]][stamp_ns(polygon.header)] = box
            for index, (conn, _, raw) in enumerate(guarded(reader.messages(connections=[camera]), path)):
                msg = _deserialize(reader, raw, conn.msgtype, path)
                stamp = stamp_ns(msg.header)
                boxes = {name: truths[name].get(stamp) for name in names}
                yield BagFrame(index, stamp, msg, boxes[names[0]] if names else None, boxes)
    except (AnyReaderError, ReaderError, OSError) as err:
        raise BagError(f'cannot read bag {path}: {err}') from err
