"""The one encoder of result files: numpy and non-finite numbers to strict JSON.

Every ``result.json`` that mpd_pin writes goes through :func:`to_jsonable` /
:func:`write_json`. Rules (docs/design.md §7):

* numpy arrays become lists, numpy scalars Python numbers, tuples lists, keys strings;
* **a non-finite number (±inf, NaN) is written as ``null``** — strict JSON has no
  infinity, and a reader in any language parses ``null``. The field's documentation
  says what ``null`` means there (for example "unbounded" for a clearance with no
  obstacle in range, "not defined" for a ratio with a zero denominator).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["to_jsonable", "write_json", "result_schema", "validate_result"]

#: The JSON Schema of result.json, shipped with the package (docs/design.md §7e).
SCHEMA_RESOURCE = ("schemas", "result.schema.json")


def result_schema() -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of result.json, both scenario kinds, units in each
    field's ``description`` (``mpd_pin/schemas/result.schema.json``; docs/design.md §7e)."""
    from importlib import resources

    path = resources.files("mpd_pin").joinpath(*SCHEMA_RESOURCE)
    return json.loads(path.read_text(encoding="utf-8"))


def validate_result(doc: Any) -> None:
    """Raise ``jsonschema.ValidationError`` unless ``doc`` (a parsed result.json) matches
    :func:`result_schema`. Needs the ``jsonschema`` package (the ``test`` extra)."""
    import jsonschema

    schema = result_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    jsonschema.Draft202012Validator(schema).validate(doc)


def to_jsonable(obj: Any) -> Any:
    """``obj`` with numpy types converted and every non-finite float replaced by ``None``."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (np.floating, float)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def readable_mode() -> int:
    """The mode a new file gets under this process's umask (0o666 & ~umask, e.g. 0644):
    temporary files from :func:`tempfile.mkstemp` are 0600, which an atomic write would
    otherwise keep."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def write_json(path: str | os.PathLike, obj: Any) -> Path:
    """Write ``to_jsonable(obj)`` to ``path`` atomically (temporary file, then ``os.replace``).

    The text is produced (and validated as strict JSON) before anything is written, so a
    failure leaves no partial file."""
    path = Path(path)
    text = json.dumps(to_jsonable(obj), indent=1, allow_nan=False)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.write("\n")
        os.chmod(tmp, readable_mode())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
