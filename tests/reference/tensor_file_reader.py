"""An independent reader of the RGL ``tensor_file`` container, written from its description.

Format (Dupuy & Jakob 2018; Mitsuba 3 ``TensorFile``): 12 bytes ``tensor_file\\0``, two
version bytes (1, 0), u32 field count; per field u16 name length, the name, u16 ndim,
u8 type code, u64 data offset, ndim x u64 shape; data little-endian, C order. Type codes
1..11: u8, i8, u16, i16, u32, i32, u64, i64, f16, f32, f64. Imports nothing of vcavity.
"""

from __future__ import annotations

import numpy as np

_CODES = {1: "<u1", 2: "<i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<u8", 8: "<i8",
          9: "<f2", 10: "<f4", 11: "<f8"}


def read_tensor_file(path) -> dict:
    """``{name: ndarray}`` of every field of a tensor file (raises ValueError when malformed)."""
    raw = open(path, "rb").read()
    if raw[:12] != b"tensor_file\x00":
        raise ValueError("not a tensor file (magic)")
    if tuple(raw[12:14]) != (1, 0):
        raise ValueError(f"unknown version {tuple(raw[12:14])}")
    position = 14
    count = int.from_bytes(raw[position:position + 4], "little")
    position += 4
    fields = {}
    for _ in range(count):
        length = int.from_bytes(raw[position:position + 2], "little")
        name = raw[position + 2:position + 2 + length].decode()
        position += 2 + length
        ndim = int.from_bytes(raw[position:position + 2], "little")
        code = raw[position + 2]
        offset = int.from_bytes(raw[position + 3:position + 11], "little")
        position += 11
        shape = tuple(int.from_bytes(raw[position + 8 * k:position + 8 * k + 8], "little") for k in range(ndim))
        position += 8 * ndim
        dtype = np.dtype(_CODES[code])
        size = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        if offset + size > len(raw):
            raise ValueError(f"field {name!r} runs past the end of the file")
        fields[name] = np.frombuffer(raw[offset:offset + size], dtype=dtype).reshape(shape)
    return fields
