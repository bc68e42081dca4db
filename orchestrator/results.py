"""Results folders and atomic writes, shared by every command."""
import json
import os
import shutil
import tempfile
from pathlib import Path


class ResultsExist(RuntimeError):
    pass


def check_out(path, force=False):
    """Refuse an existing non-empty run folder unless `force`; True when it would be replaced."""
    out = Path(path)
    if out.exists() and any(out.iterdir()):
        if not force:
            raise ResultsExist(f"results folder {out} exists and is not empty; "
                               f"choose another --out or pass --force to replace it")
        return True
    return False


def prepare_out(path, force=False):
    """Create the run folder `path`; refuse an existing non-empty one unless `force`."""
    out = Path(path)
    if check_out(out, force):
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    return out


def write_atomic(path, data, mode="w"):
    """Write `data` to `path` through a temporary file and a rename: never half-written."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, mode) as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def write_json(path, obj):
    write_atomic(path, json.dumps(obj, indent=2, sort_keys=True, default=_jsonable) + "\n")


def _jsonable(x):
    import numpy as np
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON-serialisable: {type(x).__name__}")
