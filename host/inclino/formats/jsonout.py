"""The one JSON form of every result: numpy scalars and arrays become Python
numbers and lists, NaN and infinities become null (JSON has neither, and a
reader must not guess), dict keys become strings.  Results build their
to_json from `json_safe` or `dumps`."""
from __future__ import annotations

import json
import math

import numpy as np


def json_safe(o):
    """JSON-safe copy: numpy to Python, NaN/inf to None, tuples to lists, keys to str."""
    if isinstance(o, dict):
        return {str(k): json_safe(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [json_safe(v) for v in o]
    if isinstance(o, np.ndarray):
        return json_safe(o.tolist())
    if isinstance(o, (np.bool_, bool)):
        return bool(o)
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, (np.floating, float)):
        v = float(o)
        return v if math.isfinite(v) else None
    return o


def dumps(o, indent: int | None = 2) -> str:
    """json.dumps of json_safe(o); a value JSON cannot hold is an error, never NaN in the text."""
    return json.dumps(json_safe(o), indent=indent, allow_nan=False)


def dump(o, f, indent: int | None = 2, batch: int = 1 << 16) -> None:
    """dumps(o) written to the text stream f as it is encoded (the same
    text): a long result (10^5 station pairs) is never one string in memory.
    The pieces go out in writes of about `batch` characters."""
    buf, size = [], 0
    for piece in json.JSONEncoder(indent=indent, allow_nan=False).iterencode(json_safe(o)):
        buf.append(piece)
        size += len(piece)
        if size >= batch:
            f.write("".join(buf))
            buf, size = [], 0
    f.write("".join(buf))
