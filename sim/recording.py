"""Append-only recording of the stream: the frames exactly as published, with their times.

File layout (all integers little-endian, see docs/protocol.md "Recording format")::

    header   16 bytes   magic b"SHIPRADR" | uint16 format version | uint16 schema version
                        | uint32 reserved (0)
    record   repeated   uint32 n (length of what follows the CRC) | uint32 CRC-32 of it
                        | float64 t_sim [s] | uint16 frame count k
                        | k x (uint32 frame length | frame bytes)

The writer only appends, so after a crash (kill -9, power loss) the file is a valid
recording followed by at most one partial record; :class:`RecordingReader` yields every whole
record and reports what it ignored. The CRC tells a torn or corrupted record from a valid one.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Iterator, Sequence
from pathlib import Path
from types import TracebackType
from typing import BinaryIO

from shipradar.sim.protocol import MAX_BODY_BYTES, SCHEMA_VERSION

__all__ = [
    "FORMAT_VERSION",
    "MAGIC",
    "MAX_FRAMES",
    "MAX_RECORD_BYTES",
    "Recorder",
    "RecordingError",
    "RecordingReader",
    "read_recording",
]

#: First 8 bytes of every recording.
MAGIC: bytes = b"SHIPRADR"
#: Version of the file layout (not of the message schema).
FORMAT_VERSION: int = 1
#: File layout versions this reader understands.
SUPPORTED_FORMAT_VERSIONS: tuple[int, ...] = (1,)
#: Most frames in one record (messages are 2 frames; room for later extensions).
MAX_FRAMES: int = 16
#: Largest record accepted [bytes]: one maximal body plus its topic and framing.
MAX_RECORD_BYTES: int = MAX_BODY_BYTES + 4096

_HEADER = struct.Struct("<8sHHI")
_PREFIX = struct.Struct("<II")  # record length, CRC-32
_RECORD_HEAD = struct.Struct("<dH")  # t_sim, frame count
_FRAME_LEN = struct.Struct("<I")
_RECORD_HEAD_2 = struct.Struct("<dHI")  # t_sim, frame count 2, length of the first frame
HEADER_BYTES: int = _HEADER.size


class RecordingError(ValueError):
    """A file that is not a readable shipradar recording (wrong magic, version, corruption)."""


class RecordingExistsError(FileExistsError):
    """The recording file exists and overwriting was not asked for."""


class Recorder:
    """Append-only writer of a recording.

    Parameters
    ----------
    path : str or os.PathLike
        File to create.
    overwrite : bool, optional
        Replace an existing file. When False (default) an existing file is refused with
        :class:`RecordingExistsError` and left untouched (creation is atomic, ``O_EXCL``).
    buffer_bytes : int, optional
        Size of the in-process write buffer [bytes]. Whatever is still in it is lost on
        kill -9; :meth:`flush` hands it to the operating system.

    Notes
    -----
    The engine calls :meth:`flush` at every end of scan, so a killed run keeps every scan
    that ended; ``flush(fsync=True)`` also survives a power loss.
    """

    def __init__(
        self, path: str | os.PathLike[str], *, overwrite: bool = False, buffer_bytes: int = 1 << 20
    ) -> None:
        self.path = Path(path)
        mode = "wb" if overwrite else "xb"
        try:
            self._file: BinaryIO = open(self.path, mode, buffering=buffer_bytes)  # noqa: SIM115
        except FileExistsError:
            raise RecordingExistsError(
                f"recording {self.path} already exists; choose another file or allow overwriting it"
            ) from None
        self.records = 0
        self.bytes_written = 0
        self._write_raw(_HEADER.pack(MAGIC, FORMAT_VERSION, SCHEMA_VERSION, 0))
        self._file.flush()  # a file that exists always has its header

    def _write_raw(self, data: bytes) -> None:
        self._file.write(data)
        self.bytes_written += len(data)

    @property
    def closed(self) -> bool:
        """True once :meth:`close` has run."""
        return self._file.closed

    def write(self, t_sim: float, frames: Sequence[bytes]) -> None:
        """Append one message.

        Parameters
        ----------
        t_sim : float
            Simulated time of the message [s since scenario start].
        frames : Sequence[bytes]
            The message's frames, as encoded by :func:`sim.protocol.encode`.

        Raises
        ------
        RecordingError
            If there are more than :data:`MAX_FRAMES` frames or the record would exceed
            :data:`MAX_RECORD_BYTES` (nothing is written then).
        """
        if len(frames) == 2:  # every message of the stream: [topic, body]
            topic, body = bytes(frames[0]), bytes(frames[1])
            record = b"".join((_RECORD_HEAD_2.pack(float(t_sim), 2, len(topic)), topic,
                               _FRAME_LEN.pack(len(body)), body))
        else:
            if len(frames) > MAX_FRAMES:
                raise RecordingError(f"{len(frames)} frames in one record, at most {MAX_FRAMES}")
            parts = [_RECORD_HEAD.pack(float(t_sim), len(frames))]
            for frame in frames:
                parts.append(_FRAME_LEN.pack(len(frame)))
                parts.append(bytes(frame))
            record = b"".join(parts)
        if len(record) > MAX_RECORD_BYTES:
            raise RecordingError(
                f"record of {len(record)} bytes exceeds the {MAX_RECORD_BYTES}-byte maximum"
            )
        write = self._file.write
        write(_PREFIX.pack(len(record), zlib.crc32(record)))
        write(record)
        self.bytes_written += _PREFIX.size + len(record)
        self.records += 1

    def flush(self, fsync: bool = False) -> None:
        """Hand buffered records to the operating system (and to the disk with ``fsync``).

        Parameters
        ----------
        fsync : bool, optional
            Also wait until the data is on stable storage (slow; survives power loss).
        """
        self._file.flush()
        if fsync:
            os.fsync(self._file.fileno())

    def close(self) -> None:
        """Flush and close the file (idempotent)."""
        if not self._file.closed:
            self._file.close()

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


class RecordingReader:
    """Iterate the records of a recording as ``(t_sim, frames)``.

    Parameters
    ----------
    path : str or os.PathLike
        The recording.

    Attributes
    ----------
    format_version : int
        File layout version from the header.
    schema_version : int or None
        Message schema version from the header (None when the header itself is truncated).
    records : int
        Whole records read so far.
    truncated : bool
        True once iteration met an incomplete last record (or header): the file was cut,
        typically by a killed run. Every whole record before it was yielded.
    bytes_ignored : int
        Bytes at the end of the file that were not part of a whole record.

    Raises
    ------
    RecordingError
        On opening: wrong magic or unsupported format version. While iterating: a record
        whose declared length exceeds :data:`MAX_RECORD_BYTES`, whose CRC does not match, or
        whose frames do not add up - corruption that truncation cannot explain.

    Notes
    -----
    Iterating twice reads the file twice. Frames are ``bytes`` identical to those written.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self._file: BinaryIO = open(self.path, "rb")  # noqa: SIM115
        self.records = 0
        self.truncated = False
        self.bytes_ignored = 0
        self.schema_version: int | None = None
        self.format_version: int | None = None
        try:
            self._header_truncated = self._read_header()
        except BaseException:
            self._file.close()
            raise

    def _read_header(self) -> bool:
        head = self._file.read(HEADER_BYTES)
        if len(head) < HEADER_BYTES:
            # A run killed right after creating the file: a (possibly empty) prefix of a
            # header is a recording with no records; anything else is not ours.
            if not MAGIC.startswith(head[: len(MAGIC)]):
                raise RecordingError(f"{self.path} is not a shipradar recording (bad magic)")
            return True
        magic, fmt, schema, _reserved = _HEADER.unpack(head)
        if magic != MAGIC:
            raise RecordingError(f"{self.path} is not a shipradar recording (bad magic)")
        if fmt not in SUPPORTED_FORMAT_VERSIONS:
            raise RecordingError(
                f"{self.path} has recording format version {fmt}; this reader supports "
                f"{list(SUPPORTED_FORMAT_VERSIONS)}"
            )
        self.format_version = fmt
        self.schema_version = schema
        return False

    def __iter__(self) -> Iterator[tuple[float, list[bytes]]]:
        self.records = 0
        self.truncated = False
        self.bytes_ignored = 0
        f = self._file
        size = os.fstat(f.fileno()).st_size
        if self._header_truncated:
            self.truncated = True
            self.bytes_ignored = size
            return
        f.seek(HEADER_BYTES)
        pos = HEADER_BYTES
        while pos < size:
            if size - pos < _PREFIX.size:
                break
            n, crc = _PREFIX.unpack(f.read(_PREFIX.size))
            if n > MAX_RECORD_BYTES:
                raise RecordingError(
                    f"{self.path}: record at byte {pos} declares {n} bytes, over the "
                    f"{MAX_RECORD_BYTES}-byte maximum (corrupt file)"
                )
            if size - pos - _PREFIX.size < n:
                break
            record = f.read(n)
            if len(record) < n:  # the file shrank while we read it
                break
            if zlib.crc32(record) != crc:
                raise RecordingError(
                    f"{self.path}: record at byte {pos} fails its CRC check (corrupt file)"
                )
            yield self._parse(record, pos)
            self.records += 1
            pos += _PREFIX.size + n
        if pos < size:
            self.truncated = True
            self.bytes_ignored = size - pos

    def _parse(self, record: bytes, pos: int) -> tuple[float, list[bytes]]:
        if len(record) < _RECORD_HEAD.size:
            raise RecordingError(f"{self.path}: record at byte {pos} is too short (corrupt)")
        t_sim, count = _RECORD_HEAD.unpack_from(record, 0)
        if count > MAX_FRAMES:
            raise RecordingError(
                f"{self.path}: record at byte {pos} has {count} frames, at most {MAX_FRAMES}"
            )
        frames = []
        off = _RECORD_HEAD.size
        mv = memoryview(record)
        for _ in range(count):
            if off + _FRAME_LEN.size > len(record):
                raise RecordingError(f"{self.path}: record at byte {pos} is malformed")
            (length,) = _FRAME_LEN.unpack_from(record, off)
            off += _FRAME_LEN.size
            if off + length > len(record):
                raise RecordingError(f"{self.path}: record at byte {pos} is malformed")
            frames.append(bytes(mv[off : off + length]))
            off += length
        if off != len(record):
            raise RecordingError(f"{self.path}: record at byte {pos} has trailing bytes")
        return t_sim, frames

    def close(self) -> None:
        """Close the file (idempotent)."""
        self._file.close()

    def __enter__(self) -> RecordingReader:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def read_recording(path: str | os.PathLike[str]) -> RecordingReader:
    """Open a recording for iteration over ``(t_sim, frames)``.

    Parameters
    ----------
    path : str or os.PathLike
        The recording.

    Returns
    -------
    RecordingReader
        Iterable; after iteration its ``truncated`` and ``bytes_ignored`` attributes say
        whether the file ended with an incomplete record. Use it as a context manager to
        close the file.
    """
    return RecordingReader(path)
