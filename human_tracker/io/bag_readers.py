"""Opening a rosbag2 bag for reading, as it was left: a folder with its ``metadata.yaml``, a lone
``.mcap`` file (the recorder writes the metadata last), or one cut short (power lost, disk full:
no summary, no end of file), whose complete records are read up to the cut.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from io import BytesIO
from pathlib import Path
from typing import BinaryIO

from rosbags.highlevel import AnyReader
from rosbags.interfaces import Connection
from rosbags.rosbag2 import ReaderError
from rosbags.rosbag2.storage_mcap import McapReader
from rosbags.typesys import Stores, get_typestore

__all__ = ['TYPESTORE', 'BagError', 'BareMcapReader', 'CutMcapReader', 'open_bag']

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
_MCAP_MAGIC = b'\x89MCAP0\r\n'
_MCAP_DATA_END = 0x0F
_MCAP_CHUNK = 0x06


class BagError(RuntimeError):
    """A bag cannot be read or holds no usable camera topic; the message says why."""


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
