"""Append-only recording of the stream: the frames exactly as published, with their times.

File layout, format version 2 (all integers little-endian; docs/protocol.md, "Recording
format", gives the reasons)::

    header   16 bytes   magic b"SHIPRADR" | uint16 format version (2) | uint16 schema version
                        | uint16 flags (bit 0: the writer compressed with zstd)
                        | uint16 low 16 bits of the CRC-32 of bytes 0-13
    record   repeated   sync marker (8 bytes, :data:`SYNC`)
                        | uint32 n (stored payload length) | uint16 flags (bit 0: zstd)
                        | uint16 reserved (0) | uint64 sequence number (0, 1, 2, ...)
                        | uint32 CRC-32 of the stored payload
                        | uint32 CRC-32 of the 20 header bytes after the marker
                        | payload: n bytes
    payload  (after zstd decompression when flagged)
                        float64 t_sim | uint16 frame count k | k x (uint32 length | bytes)

Each record is self-delimiting and self-checking, so a reader that meets damage (a bad
CRC, an impossible length, a duplicated or reordered record) skips to the next sync
marker whose header and payload check out, and goes on: one flipped byte costs one record,
not the rest of the file. A header CRC separate from the payload CRC means a damaged length
is never trusted. The sequence number makes a lost, duplicated or reordered record
visible and counts exactly how many records a damaged region held.

Format version 1 (no sync marker, no sequence number: ``uint32 n | uint32 CRC-32 | payload``)
is still read; it cannot be resynchronised, so damage in it ends the readable part.
"""

from __future__ import annotations

import errno
import os
import struct
import zlib
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, BinaryIO

from shipradar._framing import frames as _frames
from shipradar.sim.stream.protocol import MAX_BODY_BYTES, SCHEMA_VERSION
from shipradar.sim.stream.sink import Closing
from shipradar.sim.world.errors import BadInputError

__all__ = [
    "COMPRESSIONS",
    "FORMAT_VERSION",
    "MAGIC",
    "MAX_FRAMES",
    "MAX_RECORD_BYTES",
    "SYNC",
    "DamagedRegion",
    "Recorder",
    "RecordingError",
    "RecordingExistsError",
    "RecordingReader",
    "RecordingWriteError",
    "read_recording",
    "repair_recording",
    "verify_recording",
]

#: First 8 bytes of every recording.
MAGIC: bytes = b"SHIPRADR"
#: Version of the file layout written (not of the message schema).
FORMAT_VERSION: int = 2
#: File layout versions this reader understands.
SUPPORTED_FORMAT_VERSIONS: tuple[int, ...] = (1, 2)
#: Most frames in one record (messages are 2 frames; room for later extensions).
MAX_FRAMES: int = 16
#: Largest record payload accepted, stored or decompressed [bytes]: one maximal body plus
#: its topic and framing.
MAX_RECORD_BYTES: int = MAX_BODY_BYTES + 4096
#: Marker that starts every record of format 2. Non-ASCII at both ends so that text in a
#: payload does not reproduce it; a false match must also pass two CRC-32 checks.
SYNC: bytes = b"\xd3ZSRrec\xe1"
#: Record compression the writer offers (``--compress``).
COMPRESSIONS: tuple[str, ...] = ("none", "zstd")
#: zstd level: 3 is zstd's default, the knee of its ratio/speed curve on this data
#: (benchmarks/recording.py).
ZSTD_LEVEL: int = 3

_FLAG_ZSTD = 1
_HEADER = struct.Struct("<8sHHI")  # format 1's view: magic, version, schema, reserved
_HEADER2 = struct.Struct("<8sHHHH")  # magic, version, schema, flags, CRC-16
HEADER_BYTES: int = _HEADER.size
_REC2 = struct.Struct("<8sIHHQII")  # sync, n, flags, reserved, seq, payload CRC, header CRC
_REC2_MID = struct.Struct("<IHHQI")  # the 20 bytes the header CRC covers
REC2_HEADER_BYTES: int = _REC2.size
_U32 = struct.Struct("<I")
_PREFIX1 = struct.Struct("<II")  # format 1: record length, CRC-32
_RECORD_HEAD = struct.Struct("<dH")  # t_sim, frame count
_FRAME_LEN = struct.Struct("<I")
_RECORD_HEAD_2 = struct.Struct("<dHI")  # t_sim, frame count 2, length of the first frame


class RecordingError(ValueError, BadInputError):
    """A file that is not a readable shipradar recording (wrong magic, version, corruption)."""


class RecordingExistsError(FileExistsError, BadInputError):
    """The recording file exists and overwriting was not asked for."""


class RecordingWriteError(OSError):
    """The recording could not be written (disk full, file size limit, I/O error).

    The file is cut back to its last whole record before this is raised, so it stays a
    valid recording of everything before the failure.
    """

    def __str__(self) -> str:
        return str(self.strerror)  # the message alone, without "[Errno 28]"


def _header_crc16(head14: bytes) -> int:
    return zlib.crc32(head14) & 0xFFFF


def _file_header(schema: int, flags: int) -> bytes:
    head = struct.pack("<8sHHH", MAGIC, FORMAT_VERSION, schema, flags)
    return head + struct.pack("<H", _header_crc16(head))


def _body(t_sim: float, frames: Sequence[bytes]) -> bytes:
    """The record payload before compression: t_sim, frame count, frames with lengths."""
    if len(frames) == 2:  # every message of the stream: [topic, body]
        topic, body = frames
        return b"".join((_RECORD_HEAD_2.pack(float(t_sim), 2, len(topic)), topic,
                         _FRAME_LEN.pack(len(body)), body))
    if len(frames) > MAX_FRAMES:
        raise RecordingError(f"{len(frames)} frames in one record, at most {MAX_FRAMES}")
    parts = [_RECORD_HEAD.pack(float(t_sim), len(frames))]
    for frame in frames:
        parts.append(_FRAME_LEN.pack(len(frame)))
        parts.append(bytes(frame))
    return b"".join(parts)


def _zstd_compressor():
    import zstandard

    # content size in the frame: the reader checks it against MAX_RECORD_BYTES before it
    # allocates; no zstd checksum: the record's CRC-32 already covers the stored bytes
    return zstandard.ZstdCompressor(level=ZSTD_LEVEL, write_content_size=True,
                                    write_checksum=False)


class Recorder(Closing):
    """Append-only writer of a recording (format 2).

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
    compress : {"none", "zstd"}, optional
        Compress each record's payload on its own with zstd (level :data:`ZSTD_LEVEL`), so
        that damage still costs one record. A record is stored uncompressed when zstd does
        not make it smaller (short ``eos``/``meta`` messages).

    Notes
    -----
    The engine calls :meth:`flush` at every end of scan, so a killed run keeps every scan
    that ended; ``flush(fsync=True)`` also survives a power loss. When a write fails (disk
    full, ``RLIMIT_FSIZE``, I/O error) the file is cut back to its last whole record and
    :class:`RecordingWriteError` is raised; the recorder accepts no more records.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        overwrite: bool = False,
        buffer_bytes: int = 1 << 20,
        compress: str = "none",
    ) -> None:
        if compress not in COMPRESSIONS:
            raise RecordingError(
                f"compression must be one of {', '.join(COMPRESSIONS)}, got {compress!r}")
        self.path = Path(path)
        self.compress = compress
        self._zstd = _zstd_compressor() if compress == "zstd" else None
        flags = os.O_WRONLY | os.O_CREAT | (os.O_TRUNC if overwrite else os.O_EXCL)
        try:
            self._fd: int | None = os.open(self.path, flags | getattr(os, "O_CLOEXEC", 0), 0o644)
        except FileExistsError:
            raise RecordingExistsError(
                f"recording {self.path} already exists; choose another file or allow overwriting it"
            ) from None
        self.buffer_bytes = max(1, int(buffer_bytes))
        self.records = 0
        self.bytes_written = 0
        self.stored_payload_bytes = 0
        self.raw_payload_bytes = 0
        # what is not yet written: a bytearray, or the bytes of frame_records alone
        self._buf: bytearray | bytes = bytearray()
        self._ends: list[int] = []  # record ends inside _buf: where a failed write may be cut
        self._committed = 0  # bytes known to be in the file
        self._failed: RecordingWriteError | None = None
        header = _file_header(SCHEMA_VERSION, _FLAG_ZSTD if self._zstd else 0)
        self._buf += header
        self._ends.append(len(header))
        self.bytes_written = len(header)
        self._write_out()  # a file that exists always has its header

    @property
    def closed(self) -> bool:
        """True once :meth:`close` has run."""
        return self._fd is None

    def write(self, t_sim: float, frames: Sequence[bytes]) -> None:
        """Append one message.

        Parameters
        ----------
        t_sim : float
            Simulated time of the message [s since scenario start].
        frames : Sequence[bytes]
            The message's frames, as encoded by :func:`shipradar.sim.stream.protocol.encode`.

        Raises
        ------
        RecordingError
            If there are more than :data:`MAX_FRAMES` frames or the record would exceed
            :data:`MAX_RECORD_BYTES` (nothing is written then).
        RecordingWriteError
            If the file cannot be written (see the class Notes); also on any later call.
        """
        if self._failed is not None:
            raise self._failed
        if self._fd is None:
            raise RecordingError(f"recording {self.path} is closed")
        body = _body(t_sim, frames)
        if len(body) > MAX_RECORD_BYTES:
            raise RecordingError(
                f"record of {len(body)} bytes exceeds the {MAX_RECORD_BYTES}-byte maximum"
            )
        self.raw_payload_bytes += len(body)
        flags = 0
        if self._zstd is not None:
            packed = self._zstd.compress(body)
            if len(packed) < len(body):
                body, flags = packed, _FLAG_ZSTD
        self.stored_payload_bytes += len(body)
        mid = _REC2_MID.pack(len(body), flags, 0, self.records, zlib.crc32(body))
        # one append: a signal handler that raises between two appends cannot leave half a
        # record in the buffer
        self._buf += b"".join((SYNC, mid, _U32.pack(zlib.crc32(mid)), body))
        self._ends.append(len(self._buf))
        self.bytes_written += REC2_HEADER_BYTES + len(body)
        self.records += 1
        if len(self._buf) >= self.buffer_bytes:
            self._write_out()

    # long: 24 docstring lines; the record framing loop must give write()'s bytes exactly
    def write_many(self, records: Sequence[tuple[float, Sequence[bytes]]]) -> int | None:
        """Append several messages: the same records, byte for byte, as one :meth:`write`
        per message, framed in one loop and appended to the buffer in one piece.

        Parameters
        ----------
        records : Sequence[tuple[float, Sequence[bytes]]]
            ``(t_sim, frames)`` per message, in stream order.

        Returns
        -------
        int or None
            When every message was two ``bytes`` frames ``[topic, body]`` (the stream's, framed
            in compiled code): the length of all their frames [bytes], which the bus counts
            (:meth:`shipradar.sim.stream.bus.Bus.emit_many`) without a pass of its own;
            otherwise None.

        Raises
        ------
        RecordingError
            As :meth:`write`, for the first message that cannot be a record; the messages
            before it are appended, it and those after it are not.
        RecordingWriteError
            As :meth:`write`.
        """
        if self._failed is not None:
            raise self._failed
        if self._fd is None:
            raise RecordingError(f"recording {self.path} is closed")
        zstd = self._zstd
        if zstd is None and type(records) is list:
            # every message [topic, body] (the stream's): framed in compiled code
            # (shipradar/_frames.c, the records of the loop below byte for byte)
            framed = _frames.frame_records(records, self.records, MAX_RECORD_BYTES,
                                           len(self._buf))
            if framed is not None:
                f_blob, f_ends, f_raw, f_done = framed
                self._append_framed(f_blob, f_ends, f_raw, f_done, records)
                # all framed (else _append_framed raised): each payload is an 18-byte head
                # (time, frame count, two frame lengths) and the two frames
                return f_raw - 18 * f_done
        crc32, pack_mid, pack_u32 = zlib.crc32, _REC2_MID.pack, _U32.pack
        head2, pack_len = _RECORD_HEAD_2.pack, _FRAME_LEN.pack
        parts: list[bytes] = []
        ends: list[int] = []
        start = end = len(self._buf)
        seq = self.records
        raw = stored = 0
        error = None
        for t_sim, frames in records:
            if len(frames) == 2 and zstd is None:
                # the payload's pieces go straight into the record (no payload copy); its
                # CRC-32 is chained over them, the same value as over their join
                topic, body = frames
                head = head2(float(t_sim), 2, len(topic))
                blen = pack_len(len(body))
                n = 18 + len(topic) + len(body)  # 14-byte head, topic, 4-byte length, body
                if n > MAX_RECORD_BYTES:
                    error = RecordingError(
                        f"record of {n} bytes exceeds the {MAX_RECORD_BYTES}-byte maximum")
                    break
                mid = pack_mid(n, 0, 0, seq, crc32(body, crc32(blen, crc32(topic, crc32(head)))))
                parts += (SYNC, mid, pack_u32(crc32(mid)), head, topic, blen, body)
                raw += n
            else:
                payload = _body(t_sim, frames)
                n = len(payload)
                if n > MAX_RECORD_BYTES:
                    error = RecordingError(
                        f"record of {n} bytes exceeds the {MAX_RECORD_BYTES}-byte maximum")
                    break
                raw += n
                flags = 0
                if zstd is not None:
                    packed = zstd.compress(payload)
                    if len(packed) < n:
                        payload, flags, n = packed, _FLAG_ZSTD, len(packed)
                mid = pack_mid(n, flags, 0, seq, crc32(payload))
                parts += (SYNC, mid, pack_u32(crc32(mid)), payload)
            stored += n
            end += REC2_HEADER_BYTES + n
            ends.append(end)
            seq += 1
        if ends:
            # one append of whole records (as write): the buffer never holds half a record
            self._buf += b"".join(parts)
            self._ends += ends
            self.bytes_written += end - start
            self.records = seq
            self.raw_payload_bytes += raw
            self.stored_payload_bytes += stored
        if error is not None:
            raise error
        if len(self._buf) >= self.buffer_bytes:
            self._write_out()
        return None

    def _append_framed(self, blob: bytes, ends: list[int], raw: int, done: int,
                       records: Sequence) -> None:
        """Append the whole records ``frame_records`` made of ``records[:done]`` (``ends``:
        where each ends in the buffer); raise as
        :meth:`write_many` for ``records[done]`` when it was too large."""
        if done:
            if self._buf:
                self._buf += blob
            else:  # the records alone: kept as they are until written (no copy)
                self._buf = blob
            self._ends += ends
            self.bytes_written += len(blob)
            self.records += done
            self.raw_payload_bytes += raw
            self.stored_payload_bytes += raw
        if done < len(records):
            topic, body = records[done][1]
            raise RecordingError(
                f"record of {18 + len(topic) + len(body)} bytes exceeds the "
                f"{MAX_RECORD_BYTES}-byte maximum")
        if len(self._buf) >= self.buffer_bytes:
            self._write_out()

    def _write_out(self) -> None:
        """Write the buffer to the file; on failure cut the file to its last whole record."""
        if not self._buf or self._fd is None:
            return
        view = memoryview(self._buf)
        done = 0
        try:
            while done < len(view):
                done += os.write(self._fd, view[done:])
        except OSError as exc:
            view.release()
            self._fail(exc, done)
        view.release()
        self._committed += done
        self._buf = bytearray()
        self._ends.clear()

    def _fail(self, exc: OSError, done: int) -> None:
        whole = max((e for e in self._ends if e <= done), default=0)
        lost = sum(1 for e in self._ends if e > whole)
        keep = self._committed + whole
        if self._fd is not None:
            try:
                os.ftruncate(self._fd, keep)  # shrinking needs no space, passes RLIMIT_FSIZE
            except OSError:
                pass
        on_disk = self.records - lost
        why = {errno.ENOSPC: "no space left on the device",
               errno.EFBIG: "file size limit reached",
               errno.EDQUOT: "disk quota exceeded"}.get(exc.errno or 0,
                                                        exc.strerror or str(exc))
        self._committed = keep
        self._buf = bytearray()
        self._ends.clear()
        self.bytes_written = keep
        self.records = max(on_disk, 0)
        self._failed = RecordingWriteError(
            exc.errno,
            f"recording {self.path}: cannot write ({why}); it keeps its first {self.records} "
            f"record(s), {keep} bytes, and ends at a whole record "
            f"(shipradar recording verify {self.path})",
        )
        raise self._failed from exc

    def flush(self, fsync: bool = False) -> None:
        """Hand buffered records to the operating system (and to the disk with ``fsync``).

        Parameters
        ----------
        fsync : bool, optional
            Also wait until the data is on stable storage (slow; survives power loss).

        Raises
        ------
        RecordingWriteError
            See the class Notes.
        """
        if self._failed is not None:
            raise self._failed
        self._write_out()
        if fsync and self._fd is not None:
            os.fsync(self._fd)

    def close(self) -> None:
        """Write what is buffered and close the file (idempotent).

        Raises
        ------
        RecordingWriteError
            If the last buffered records cannot be written (the file is closed anyway).
        """
        if self._fd is None:
            return
        try:
            if self._failed is None:
                self._write_out()
        finally:
            os.close(self._fd)
            self._fd = None



# =========================================================================== reading
@dataclass(frozen=True)
class DamagedRegion:
    """Bytes of a recording that were skipped.

    Attributes
    ----------
    start, end : int
        File offsets [bytes], ``end`` exclusive.
    records : int
        Records lost in it: exact when a valid record follows (from the sequence numbers),
        otherwise the number of record headers found in it (at least 1).
    reason : str
        What was wrong at ``start``.
    """

    start: int
    end: int
    records: int
    reason: str

    @property
    def bytes(self) -> int:
        """Length of the region [bytes]."""
        return self.end - self.start


class _Window:
    """Reads of a file through a 1 MiB window: cheap record-by-record parsing and scanning."""

    def __init__(self, f: BinaryIO, size: int, chunk: int = 1 << 20):
        self.f, self.size, self.chunk = f, size, chunk
        self.start = 0
        self.buf = b""

    def get(self, pos: int, n: int) -> bytes:
        """Bytes ``[pos, pos + n)``, fewer at the end of the file."""
        n = max(0, min(n, self.size - pos))
        off = pos - self.start
        if off < 0 or off + n > len(self.buf):
            self.f.seek(pos)
            self.buf = self.f.read(min(max(n, self.chunk), self.size - pos))
            self.start = pos
            off = 0
        return self.buf[off : off + n]

    def find(self, needle: bytes, pos: int) -> int:
        """Offset of the first ``needle`` at or after ``pos``, -1 if none before the end."""
        while pos < self.size:
            self.get(pos, self.chunk)
            i = self.buf.find(needle, pos - self.start)
            if i >= 0:
                return self.start + i
            end = self.start + len(self.buf)
            if end >= self.size:
                return -1
            pos = max(pos + 1, end - len(needle) + 1)
        return -1


class _Bad(Exception):
    """A candidate record that does not check out (internal to the reader)."""


class RecordingReader(Closing):
    """Iterate the valid records of a recording as ``(t_sim, frames)``.

    Parameters
    ----------
    path : str or os.PathLike
        The recording.
    strict : bool, optional
        Raise :class:`RecordingError` at the first damaged record instead of skipping it.
        A truncated tail is never an error.
    max_bytes : int or None, optional
        Refuse files larger than this [bytes] on opening (None: no limit).

    Attributes
    ----------
    format_version : int or None
        File layout version from the header (None when the header is damaged or cut).
    schema_version : int or None
        Message schema version from the header (None when the header is damaged or cut).
    compressed : bool or None
        The writer's compression flag from a format-2 header.
    records : int
        Valid records read so far.
    truncated : bool
        True once iteration met a torn or zero-filled tail (a killed run, a power loss):
        a partial last record, zeros, or both. Every whole record before it was yielded.
    bytes_ignored : int
        Bytes of that tail.
    damaged : list of DamagedRegion
        Regions skipped because they failed their checks.
    bytes_skipped, records_skipped : int
        Totals over :attr:`damaged`.

    Raises
    ------
    RecordingError
        On opening: a file with neither a valid header nor any valid record (not a
        recording), or an unsupported format version. While iterating, with ``strict``
        only: the first damaged region.

    Notes
    -----
    Nothing that fails a check is ever yielded: a record is yielded only when its header
    CRC, payload CRC, sequence number (strictly after the last one yielded) and frame
    lengths all agree. Iterating twice reads the file twice. Frames are ``bytes`` identical
    to those written.
    """

    def __init__(
        self, path: str | os.PathLike[str], *, strict: bool = False, max_bytes: int | None = None
    ) -> None:
        self.path = Path(path)
        self.strict = strict
        self._file: BinaryIO = open(self.path, "rb")  # noqa: SIM115
        self.schema_version: int | None = None
        self.format_version: int | None = None
        self.compressed: bool | None = None
        self._reset()
        try:
            size = os.fstat(self._file.fileno()).st_size
            if max_bytes is not None and size > max_bytes:
                raise RecordingError(
                    f"{self.path} is {size} bytes, over the {max_bytes}-byte limit")
            self._open_state = self._read_header(size)
        except BaseException:
            self._file.close()
            raise

    def _reset(self) -> None:
        self.records = 0
        self.truncated = False
        self.bytes_ignored = 0
        self.damaged: list[DamagedRegion] = []

    @property
    def bytes_skipped(self) -> int:
        """Bytes in damaged regions."""
        return sum(r.bytes for r in self.damaged)

    @property
    def records_skipped(self) -> int:
        """Records lost in damaged regions (see :class:`DamagedRegion`)."""
        return sum(r.records for r in self.damaged)

    # -- header -----------------------------------------------------------------------
    def _read_header(self, size: int) -> str:
        """Classify the file: ``"v1"``, ``"v2"``, ``"empty"`` (cut in its header) or
        ``"v2-damaged-header"``; raise when it is not a recording at all."""
        head = self._file.read(HEADER_BYTES)
        if len(head) == HEADER_BYTES and head[:8] == MAGIC:
            _magic, fmt, schema, reserved = _HEADER.unpack(head)
            # format 1's reserved word is 0; a format-2 header whose version was damaged
            # into 1 has flags and a CRC there, and a record marker after it
            if fmt == 1 and reserved == 0 and self._file.read(len(SYNC)) != SYNC:
                self.format_version, self.schema_version = 1, schema
                return "v1"
            _m, _f, _s, flags, crc16 = _HEADER2.unpack(head)
            if _header_crc16(head[:14]) == crc16:
                if fmt not in SUPPORTED_FORMAT_VERSIONS:
                    raise RecordingError(
                        f"{self.path} has recording format version {fmt}; this reader "
                        f"supports {list(SUPPORTED_FORMAT_VERSIONS)}"
                    )
                self.format_version, self.schema_version = fmt, schema
                self.compressed = bool(flags & _FLAG_ZSTD)
                return "v2"
        stripped = head.rstrip(b"\0")
        if self._nonzero_end(size, 0) <= HEADER_BYTES and MAGIC.startswith(
                stripped[: len(MAGIC)]) and (len(stripped) <= len(MAGIC)
                                             or stripped[8] in SUPPORTED_FORMAT_VERSIONS):
            # A run killed (or a power loss) right after creating the file: a prefix of a
            # header, possibly zero-filled, is a recording with no records.
            return "empty"
        # The header fails its checks. A damaged header of a format-2 file is recoverable
        # (every record carries its own checks); a file with no valid record is not ours.
        if self._first_valid_record(size) is not None:
            if self.strict:
                raise RecordingError(f"{self.path}: the file header is damaged")
            return "v2-damaged-header"
        if head[:8] == MAGIC:
            fmt = _HEADER.unpack(head)[1]
            raise RecordingError(
                f"{self.path} has recording format version {fmt}; this reader supports "
                f"{list(SUPPORTED_FORMAT_VERSIONS)}"
            )
        raise RecordingError(f"{self.path} is not a shipradar recording (bad magic)")

    def _first_valid_record(self, size: int) -> int | None:
        win = _Window(self._file, size)
        pos = win.find(SYNC, 0)
        while pos >= 0:
            try:
                self._record_at(win, pos)
                return pos
            except _Bad:
                pos = win.find(SYNC, pos + 1)
        return None

    def _nonzero_end(self, size: int, pos: int) -> int:
        """Offset just after the last non-zero byte at or after ``pos`` (``pos`` if none)."""
        end = size
        step = 1 << 16
        while end > pos:
            lo = max(pos, end - step)
            self._file.seek(lo)
            chunk = self._file.read(end - lo).rstrip(b"\0")
            if chunk:
                return lo + len(chunk)
            end = lo
        return pos

    # -- iteration --------------------------------------------------------------------
    def __iter__(self) -> Iterator[tuple[float, list[bytes]]]:
        self._reset()
        size = os.fstat(self._file.fileno()).st_size
        state = self._open_state
        if state == "empty":
            self.truncated = True
            self.bytes_ignored = size
            return
        if state == "v1":
            yield from self._iter_v1(size)
        else:
            yield from self._iter_v2(size, damaged_header=state == "v2-damaged-header")

    def _damage(self, start: int, end: int, records: int, reason: str) -> None:
        region = DamagedRegion(start, end, max(0, records), reason)
        self.damaged.append(region)
        if self.strict:
            raise RecordingError(f"{self.path}: {reason} at byte {start} (corrupt file)")

    def _record_at(self, win: _Window, pos: int) -> tuple[int, int, int, bytes]:
        """Check the record at ``pos``: ``(seq, flags, end, stored payload)`` or _Bad.

        _Bad's args: (reason, torn) where torn means the header checks out but the record
        runs past the end of the file.
        """
        head = win.get(pos, REC2_HEADER_BYTES)
        if len(head) < REC2_HEADER_BYTES:
            raise _Bad("incomplete record header", True)
        sync, n, flags, reserved, seq, crc, hcrc = _REC2.unpack(head)
        if sync != SYNC:
            raise _Bad("no record marker", False)
        if zlib.crc32(head[8:28]) != hcrc:
            raise _Bad("record header fails its CRC check", False)
        if n > MAX_RECORD_BYTES:
            raise _Bad(f"record declares {n} bytes, over the {MAX_RECORD_BYTES}-byte maximum",
                       False)
        end = pos + REC2_HEADER_BYTES + n
        if end > win.size:
            raise _Bad("record runs past the end of the file", True)
        payload = win.get(pos + REC2_HEADER_BYTES, n)
        if zlib.crc32(payload) != crc:
            raise _Bad("record fails its CRC check", False)
        if flags & ~_FLAG_ZSTD or reserved:
            raise _Bad(f"record has unknown flags {flags:#x}", False)
        return seq, flags, end, payload

    def _iter_v2(self, size: int, *, damaged_header: bool) -> Iterator[tuple[float, list[bytes]]]:
        win = _Window(self._file, size)
        pos = HEADER_BYTES
        if damaged_header:
            first = self._first_valid_record(size)
            assert first is not None
            self._damage(0, first, 0, "file header is damaged")
            pos = first
        expected = 0
        bad_start: int | None = None  # start of the damaged region being skipped
        bad_reason = ""
        bad_headers = 0  # records in it whose header checked out (lower bound of the loss)
        while pos < size:
            try:
                seq, flags, end, payload = self._record_at(win, pos)
                if seq < expected:
                    raise _Bad(f"record #{seq} repeats or comes out of order "
                               f"(expected #{expected} or later)", False)
                t_sim, frames = self._parse(self._unpack(payload, flags))
            except _Bad as bad:
                reason, torn = bad.args
                nxt = win.find(SYNC, pos + 1)
                if nxt < 0 and self._is_torn_tail(win, pos, torn):
                    if bad_start is not None:
                        self._damage(bad_start, pos, max(1, bad_headers), bad_reason)
                        bad_start = None
                    self.truncated = True
                    self.bytes_ignored = size - pos
                    return
                if bad_start is None:
                    bad_start, bad_reason, bad_headers = pos, reason, 0
                    if self.strict:
                        self._damage(pos, pos + 1, 1, reason)
                if reason not in ("no record marker", "record header fails its CRC check"):
                    bad_headers += 1
                if nxt < 0:
                    break
                pos = nxt
                continue
            if bad_start is not None or seq > expected:
                start = pos if bad_start is None else bad_start
                reason = bad_reason if bad_start is not None else (
                    f"record(s) #{expected} to #{seq - 1} missing")
                self._damage(start, pos, seq - expected, reason)
                bad_start = None
            expected = seq + 1
            self.records += 1
            yield t_sim, frames
            pos = end
        if bad_start is not None:
            self._damage(bad_start, size, max(1, bad_headers), bad_reason)

    def _is_torn_tail(self, win: _Window, pos: int, torn: bool) -> bool:
        """Whether ``[pos, end of file)`` is what a killed writer or a power loss leaves.

        That is: zeros only; or, once trailing zeros are removed, a prefix of a record
        marker; or a record whose header checks out and whose non-zero bytes stop before
        its declared end (the rest never reached the disk, or was zero-filled).
        """
        end = self._nonzero_end(win.size, pos)
        if end == pos:
            return True
        if end - pos > REC2_HEADER_BYTES + MAX_RECORD_BYTES:
            return False
        data = win.get(pos, end - pos)
        if len(data) <= len(SYNC):
            return SYNC.startswith(data)
        if not data.startswith(SYNC):
            return False
        if len(data) < REC2_HEADER_BYTES:
            return True  # cut inside the header, after the marker: nothing contradicts it
        head = win.get(pos, REC2_HEADER_BYTES)
        _s, n, _f, _r, _seq, _crc, hcrc = _REC2.unpack(head)
        if zlib.crc32(head[8:28]) != hcrc or n > MAX_RECORD_BYTES:
            return False
        return torn or len(data) < REC2_HEADER_BYTES + n

    def _unpack(self, payload: bytes, flags: int) -> bytes:
        if not flags & _FLAG_ZSTD:
            return payload
        import zstandard

        try:
            params = zstandard.get_frame_parameters(payload)
            if params.content_size > MAX_RECORD_BYTES:  # also the "unknown size" sentinel
                raise _Bad("compressed record declares an oversized payload", False)
            return zstandard.ZstdDecompressor().decompress(
                payload, max_output_size=MAX_RECORD_BYTES)
        except zstandard.ZstdError as exc:
            raise _Bad(f"compressed record does not decompress ({exc})", False) from None

    def _iter_v1(self, size: int) -> Iterator[tuple[float, list[bytes]]]:
        """Format 1: no marker to resynchronise on, so damage ends the readable part."""
        win = _Window(self._file, size)
        pos = HEADER_BYTES
        while pos < size:
            try:
                prefix = win.get(pos, _PREFIX1.size)
                if len(prefix) < _PREFIX1.size:
                    raise _Bad("incomplete record header", True)
                n, crc = _PREFIX1.unpack(prefix)
                if n > MAX_RECORD_BYTES:
                    raise _Bad(f"record declares {n} bytes, over the {MAX_RECORD_BYTES}-byte "
                               f"maximum", False)
                if size - pos - _PREFIX1.size < n:
                    raise _Bad("record runs past the end of the file", True)
                record = win.get(pos + _PREFIX1.size, n)
                if zlib.crc32(record) != crc:
                    raise _Bad("record fails its CRC check", False)
                item = self._parse(record)
            except _Bad as bad:
                reason, torn = bad.args
                end = self._nonzero_end(size, pos)
                if end == pos or (torn and end - pos <= _PREFIX1.size + MAX_RECORD_BYTES):
                    self.truncated = True
                    self.bytes_ignored = size - pos
                else:
                    self._damage(pos, size, 1, reason)
                return
            self.records += 1
            yield item
            pos += _PREFIX1.size + n

    @staticmethod
    def _parse(record: bytes) -> tuple[float, list[bytes]]:
        if len(record) < _RECORD_HEAD.size:
            raise _Bad("record is too short", False)
        t_sim, count = _RECORD_HEAD.unpack_from(record, 0)
        if count > MAX_FRAMES:
            raise _Bad(f"record has {count} frames, at most {MAX_FRAMES}", False)
        frames = []
        off = _RECORD_HEAD.size
        mv = memoryview(record)
        for _ in range(count):
            if off + _FRAME_LEN.size > len(record):
                raise _Bad("record is malformed (frame lengths)", False)
            (length,) = _FRAME_LEN.unpack_from(record, off)
            off += _FRAME_LEN.size
            if off + length > len(record):
                raise _Bad("record is malformed (frame lengths)", False)
            frames.append(bytes(mv[off : off + length]))
            off += length
        if off != len(record):
            raise _Bad("record is malformed (trailing bytes)", False)
        return t_sim, frames

    def report(self) -> dict[str, Any]:
        """Damage and truncation found by the last iteration, JSON-ready."""
        return {
            "records": self.records,
            "truncated": self.truncated,
            "bytes_ignored": self.bytes_ignored,
            "damaged_regions": len(self.damaged),
            "bytes_skipped": self.bytes_skipped,
            "records_skipped": self.records_skipped,
        }

    def close(self) -> None:
        """Close the file (idempotent)."""
        self._file.close()



def read_recording(
    path: str | os.PathLike[str], *, strict: bool = False, max_bytes: int | None = None
) -> RecordingReader:
    """Open a recording for iteration over its valid records, ``(t_sim, frames)``.

    Parameters
    ----------
    path : str or os.PathLike
        The recording.
    strict : bool, optional
        Raise :class:`RecordingError` at the first damaged record (default: skip it).
    max_bytes : int or None, optional
        Refuse files larger than this [bytes].

    Returns
    -------
    RecordingReader
        Iterable; after iteration its ``truncated``, ``bytes_ignored``, ``damaged``,
        ``bytes_skipped`` and ``records_skipped`` attributes say what was not yielded. Use
        it as a context manager to close the file.
    """
    return RecordingReader(path, strict=strict, max_bytes=max_bytes)


# =========================================================================== verify, repair
def verify_recording(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a whole recording and report what it holds and what is wrong with it.

    Parameters
    ----------
    path : str or os.PathLike
        The recording.

    Returns
    -------
    dict
        JSON-ready: ``file``, ``format_version``, ``schema_version``, ``compressed``,
        ``bytes``, ``records``, ``frames`` (multipart frames in all records),
        ``records_by_topic``, ``t_first``/``t_last`` [s simulated], ``sensors`` (from
        ``meta`` and ``eos`` messages), ``truncated``, ``bytes_ignored``,
        ``damaged_regions`` (count), ``bytes_skipped``, ``records_skipped``, ``damage``
        (each region: ``start``, ``end``, ``records``, ``reason``) and ``status``:
        ``"clean"``, ``"truncated"`` or ``"damaged"``.

    Raises
    ------
    RecordingError
        If the file is not a readable recording (the command's exit 2).
    """
    from collections import Counter

    from shipradar.sim.stream.protocol import ProtocolError, decode

    topics: Counter[str] = Counter()
    sensors: set[str] = set()
    frames = 0
    t_first = t_last = None
    with read_recording(path) as reader:
        for t_sim, msg in reader:
            frames += len(msg)
            topic = bytes(msg[0]).decode("utf-8", "backslashreplace") if msg else ""
            topics[topic] += 1
            if t_first is None:
                t_first = t_sim
            t_last = t_sim
            if topic in ("meta", "eos"):
                try:
                    sensor = decode(msg)[2].get("sensor")
                except (ProtocolError, ValueError, TypeError):
                    sensor = None
                if isinstance(sensor, str):
                    sensors.add(sensor)
        status = "damaged" if reader.damaged else "truncated" if reader.truncated else "clean"
        return {
            "file": str(path),
            "status": status,
            "format_version": reader.format_version,
            "schema_version": reader.schema_version,
            "compressed": reader.compressed,
            "bytes": os.path.getsize(path),
            "records": reader.records,
            "frames": frames,
            "records_by_topic": dict(topics),
            "t_first": t_first,
            "t_last": t_last,
            "sensors": sorted(sensors),
            **{k: v for k, v in reader.report().items() if k != "records"},
            "damage": [asdict(r) for r in reader.damaged],
        }


def repair_recording(
    path: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    overwrite: bool = False,
    compress: str = "none",
) -> dict[str, Any]:
    """Copy every valid record of a recording into a new, clean format-2 recording.

    Parameters
    ----------
    path : str or os.PathLike
        The damaged (or old-format) recording; only read.
    out : str or os.PathLike
        The new file. Refused when it exists, unless ``overwrite``; always refused when it
        is the input itself.
    overwrite : bool, optional
        Replace an existing ``out``.
    compress : {"none", "zstd"}, optional
        Compression of the new file.

    Returns
    -------
    dict
        JSON-ready: ``file``, ``out``, ``records_written`` and the input's damage report
        (see :meth:`RecordingReader.report`).

    Raises
    ------
    RecordingError
        If the input is not a readable recording, or ``out`` is the input.
    RecordingExistsError
        If ``out`` exists and ``overwrite`` is False.
    """
    src, dst = Path(path), Path(out)
    if dst.exists() and src.exists() and os.path.samefile(src, dst):
        raise RecordingError(f"repair: OUT {dst} is the input file itself; give a new file")
    with read_recording(src) as reader:
        if dst.exists() and not overwrite:
            raise RecordingExistsError(
                f"repair: OUT {dst} exists; pass --overwrite to replace it")
        tmp = dst.with_name(f".{dst.name}.repair-{os.getpid()}")
        try:
            with Recorder(tmp, overwrite=True, compress=compress) as rec:
                for t_sim, frames in reader:
                    rec.write(t_sim, frames)
            os.replace(tmp, dst)  # the old OUT stays whole until the new one is complete
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        return {"file": str(src), "out": str(dst), "records_written": rec.records,
                **{k: v for k, v in reader.report().items() if k != "records"}}
