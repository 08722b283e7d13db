"""The compiled CRC-32 (shipradar/_frames.c) is zlib's at every length, offset and starting
value: by carry-less multiplication for the whole 16-byte blocks of 64 bytes or more where
the processor has it, zlib's crc32 for the rest."""

from __future__ import annotations

import platform
import zlib

import numpy as np
import pytest

_frames = pytest.importorskip("shipradar._frames")


def test_crc32_is_zlibs_at_every_length_offset_and_start():
    rng = np.random.default_rng(5)
    data = rng.integers(0, 256, 9000, dtype=np.uint8).tobytes()
    view = memoryview(data)
    lengths = [*range(0, 200), 255, 256, 257, 1023, 1024, 1025, 4096, 6850, 8191]
    for n in lengths:
        for offset in (0, 1, 7, 8, 15, 33):
            for start in (0, 1, 0xFFFFFFFF, int(rng.integers(0, 2**32))):
                piece = view[offset:offset + n]
                assert _frames.crc32(piece, start) == zlib.crc32(piece, start), (n, offset)


def test_crc32_of_patterns_that_stress_the_folding():
    for fill in (b"\x00", b"\xff", b"\x80", b"\x01"):
        for n in (64, 80, 128, 1000, 65536 + 48):
            assert _frames.crc32(fill * n) == zlib.crc32(fill * n)
    big = np.random.default_rng(1).integers(0, 256, 3_000_000, dtype=np.uint8).tobytes()
    assert _frames.crc32(big) == zlib.crc32(big)
    assert _frames.crc32(big, 12345) == zlib.crc32(big, 12345)


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86-64 only")
def test_pclmul_is_reported_consistently():
    assert _frames.uses_pclmul() in (True, False)
