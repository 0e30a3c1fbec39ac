"""Writer of the ``tensor_file`` container of the RGL measured-BSDF format.

Layout (little-endian), as Mitsuba 3 (``TensorFile``) and pbrt-v4 read it: the 12 bytes
``b"tensor_file\\0"``, the version bytes ``1, 0``, the number of fields (u32); then per
field its name length (u16), name (UTF-8), number of dimensions (u16), type code (u8),
byte offset of its data (u64) and its shape (u64 each); then the data of every field,
C order, each starting at a multiple of 8 bytes. Type codes: u8 = 1, i8 = 2, u16 = 3,
i16 = 4, u32 = 5, i32 = 6, u64 = 7, i64 = 8, f16 = 9, f32 = 10, f64 = 11.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

MAGIC = b"tensor_file\0"
VERSION = (1, 0)
ALIGN = 8
TYPE_CODES = {np.dtype(np.uint8): 1, np.dtype(np.int8): 2, np.dtype(np.uint16): 3, np.dtype(np.int16): 4,
              np.dtype(np.uint32): 5, np.dtype(np.int32): 6, np.dtype(np.uint64): 7, np.dtype(np.int64): 8,
              np.dtype(np.float16): 9, np.dtype(np.float32): 10, np.dtype(np.float64): 11}


def write_tensor_file(path, fields: dict) -> int:
    """Write ``fields`` (name -> array; a ``str`` becomes a u8 array of its UTF-8 bytes).

    Returns
    -------
    int
        The file size in bytes.

    Raises
    ------
    ValueError
        An array of a type the format has no code for.
    """
    arrays = {}
    for name, value in fields.items():
        array = np.frombuffer(value.encode(), dtype=np.uint8) if isinstance(value, str) else np.asarray(value)
        array = np.ascontiguousarray(array, dtype=array.dtype.newbyteorder("<"))
        if array.dtype.newbyteorder("=") not in TYPE_CODES:
            raise ValueError(f"field {name!r}: dtype {array.dtype} has no tensor_file type code")
        arrays[name] = array
    header = bytearray(MAGIC + struct.pack("<BBI", *VERSION, len(arrays)))
    offset_slots = {}
    for name, array in arrays.items():
        label = name.encode()
        header += struct.pack("<H", len(label)) + label
        header += struct.pack("<HB", array.ndim, TYPE_CODES[array.dtype.newbyteorder("=")])
        offset_slots[name] = len(header)
        header += struct.pack("<Q", 0) + struct.pack(f"<{array.ndim}Q", *array.shape)
    position, offsets = len(header), {}
    for name, array in arrays.items():
        position = -(-position // ALIGN) * ALIGN
        offsets[name] = position
        position += array.nbytes
    for name, slot in offset_slots.items():
        header[slot:slot + 8] = struct.pack("<Q", offsets[name])
    with open(Path(path), "wb") as out:
        out.write(header)
        for name, array in arrays.items():
            out.write(b"\0" * (offsets[name] - out.tell()))
            out.write(array.tobytes())
        return out.tell()
