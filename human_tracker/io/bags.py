"""rosbag2 bags in and out (sqlite3 and mcap) through the ``rosbags`` library, no ROS needed.

Camera topics hold ``sensor_msgs/msg/Image`` or ``CompressedImage``; ground truth is
``geometry_msgs/msg/PolygonStamped`` on ``/ground_truth/<target>`` (the target's box as four
corners, or no points where the target is out of view).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import BinaryIO, TypeVar

import cv2
import numpy as np
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.interfaces import Connection
from rosbags.rosbag2 import ReaderError, StoragePlugin, Writer
from rosbags.rosbag2.storage_mcap import McapReader
from rosbags.typesys import Stores, get_typestore

from human_tracker.io.images import stamp_ns
from human_tracker.scenes.generator import SceneSpec, render_scene
from human_tracker.vision.geometry.camera import default_camera_matrix

_LOG = logging.getLogger(__name__)
_MCAP_MAGIC = b'\x89MCAP0\r\n'
_MCAP_DATA_END = 0x0F
_MCAP_CHUNK = 0x06

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

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
Box = tuple[float, float, float, float]
T = TypeVar('T')


class BagError(RuntimeError):
    """A bag cannot be read or holds no usable camera topic; the message says why."""


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


class BareMcapReader:
    """Reads one ``.mcap`` file with no ``metadata.yaml`` beside it (as ``ros2 bag record`` can leave one).

    The part of :class:`rosbags.highlevel.AnyReader`'s interface the package uses:
    ``connections``, ``start_time``, ``messages(connections, start)`` and ``deserialize``;
    the topics, types and counts come from the file's own summary.
    """

    def __init__(self, path: Path) -> None:
        self.storage = McapReader(path)

    @property
    def connections(self) -> list[Connection]:
        """The file's topics."""
        return self.storage.connections

    @property
    def start_time(self) -> int:
        """Timestamp of the first message, nanoseconds."""
        return self.storage.metadata.start_time

    def open(self) -> None:
        """Read the file's summary."""
        self.storage.open()

    def close(self) -> None:
        """Close the file."""
        self.storage.close()

    def messages(
        self, connections: Iterable[Connection] = (), start: int | None = None
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """``(connection, timestamp, raw)`` in time order, of ``connections`` (all when empty), from ``start``."""
        yield from self.storage.messages(list(connections) or self.connections, start=start)

    def deserialize(self, raw: bytes, msgtype: str) -> object:
        """A message from its CDR bytes."""
        return TYPESTORE.deserialize_cdr(raw, msgtype)

    def __enter__(self) -> BareMcapReader:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class CutMcapReader(BareMcapReader):
    """An ``.mcap`` file cut short: every complete record before the cut, in order.

    Its summary and footer were never written, so the topics, types and counts come from a scan
    of the records that are whole (MCAP's records each carry their length), and of the complete
    records of an uncompressed chunk the cut fell in. ``note`` says how many messages and
    seconds were recovered.
    """

    note = ''

    def open(self) -> None:
        """Find the end of the last complete record and read the records up to it, then those
        of the chunk the cut fell in."""
        storage = self.storage
        storage.bio = bio = storage.path.open('rb')
        try:
            if bio.read(len(_MCAP_MAGIC)) != _MCAP_MAGIC or bio.read(1) != b'\x01':
                raise ReaderError(f'{storage.path} is not an MCAP file')
            header = int.from_bytes(bio.read(8), 'little')
            storage.data_start = bio.tell() + header
            size = bio.seek(0, 2)
            position, opcode = _complete_records(bio, storage.data_start, size, stop=_MCAP_DATA_END)
            storage.data_end = position
            storage.meta_scan()
            records = _uncompressed_chunk_records(bio, position + 9, size) if opcode == _MCAP_CHUNK else b''
            # The cut chunk's records, read by a second reader sharing the file's schemas and channels.
            self.tail = McapReader(storage.path)
            self.tail.bio, self.tail.data_end = BytesIO(records), len(records)
            self.tail.schemas, self.tail.channels = storage.schemas, storage.channels
            self.tail.connections = list(storage.connections)
            self.tail.meta_scan()
        except BaseException:
            storage.close()
            raise
        first, second = storage.statistics, self.tail.statistics
        storage.connections = [
            c._replace(msgcount=first.channel_message_counts.get(c.id, 0) + second.channel_message_counts.get(c.id, 0))
            for c in self.tail.connections
        ]
        stamps = [t for stats in (first, second) if stats.message_count for t in (stats.start_time, stats.end_time)]
        count = first.message_count + second.message_count
        start, end = (min(stamps), max(stamps)) if stamps else (2**63 - 1, -1)
        storage.metadata = storage.metadata._replace(
            start_time=start, end_time=end + 1, duration=end - start + 1 if count else 0, message_count=count
        )
        self.note = (
            f'{storage.path} was cut short (no end of file: the recording never finished): read {count} '
            f'messages over {(end - start) / 1e9 if count else 0.0:.1f} s from the {size} bytes written'
        )

    def messages(
        self, connections: Iterable[Connection] = (), start: int | None = None
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """The complete records' messages, then those of the chunk the cut fell in."""
        wanted = list(connections) or self.connections
        yield from self.storage.messages_scan(wanted, start=start)
        yield from self.tail.messages_scan(wanted, start=start)


def open_bag(path: str | Path) -> AnyReader | BareMcapReader:
    """An unopened reader of a rosbag2 bag: its folder, a file in it, or a bare ``.mcap`` file; a
    recording of one ``.mcap`` cut short (no end of file: power lost, disk full) is read up to
    the cut (:class:`CutMcapReader`, whose ``note`` says what it recovered).

    Raises:
        BagError: Nothing is there.
    """
    path = Path(path)
    if not path.exists():
        raise BagError(f'cannot read bag {path}: it does not exist')
    files = [path] if path.is_file() else sorted(path.glob('*.mcap'))
    if len(files) == 1 and files[0].suffix == '.mcap' and _cut_short(files[0]):
        return CutMcapReader(files[0])
    folder = path.parent if path.is_file() else path
    if not (folder / 'metadata.yaml').exists():
        # ros2 bag record writes metadata.yaml last: a recording stopped hard has only its file.
        if len(files) == 1 and files[0].suffix == '.mcap':
            return BareMcapReader(files[0])
        raise BagError(f'cannot read bag {path}: no metadata.yaml beside it and not one .mcap file')
    return AnyReader([path.parent if path.is_file() else path], default_typestore=TYPESTORE)


def _uncompressed_chunk_records(bio: BinaryIO, start: int, size: int) -> bytes:
    """The complete records (schemas, channels, messages) of the chunk whose body starts at
    ``start`` and was cut at ``size``, as top-level MCAP records; none if the chunk is
    compressed (a cut compressed stream cannot be read)."""
    bio.seek(start + 28)  # message start and end times, uncompressed size, CRC
    if bio.read(int.from_bytes(bio.read(4), 'little')):  # the compression's name
        return b''
    first = bio.seek(8, 1)  # past the records' length
    end, _ = _complete_records(bio, first, size)
    bio.seek(first)
    return bio.read(end - first)


def _complete_records(bio: BinaryIO, position: int, size: int, stop: int | None = None) -> tuple[int, int]:
    """Where the MCAP records from ``position`` stop being complete within ``size`` bytes (each
    is an opcode, a length and that many bytes), or the record of opcode ``stop`` starts; and
    the opcode of the record found there (0: none, the bytes ended between records)."""
    while position + 9 <= size:
        bio.seek(position)
        opcode, length = bio.read(1)[0], int.from_bytes(bio.read(8), 'little')
        if opcode == stop or position + 9 + length > size:
            return position, opcode
        position += 9 + length
    return position, 0


def _cut_short(path: Path) -> bool:
    """Whether an ``.mcap`` file lacks its closing magic (its writer never finished it)."""
    with path.open('rb') as handle:
        if handle.seek(0, 2) < 2 * len(_MCAP_MAGIC):
            return False
        handle.seek(-len(_MCAP_MAGIC), 2)
        return handle.read() != _MCAP_MAGIC


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
