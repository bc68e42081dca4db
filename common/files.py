"""The one writer of every file the project makes: JSON, CSV, TOML, text, npz, PNG, and the
frames of the ParaView series; and the reader of text inputs (case files, scripts, tables),
whose errors name the file and the position. Each file is written under a temporary name in
its folder and renamed into place, so that no reader ever sees it half-written, with the
mode a plain `open` would give it under the user's umask (0644 under umask 022), so that
results in a shared folder or a Docker volume are readable by others.

A results folder carries a marker file (MARKER) that lists, below its first line, every file
and folder the project wrote in it (`record`, called by every writer here): what `--force`
may replace, and nothing else (`unrecorded`).
"""
import json
import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path

MARKER = ".yade-fenicsx-results"
HEADER = ("results folder written by yade-fenicsx-coupling; `--force` may replace what the "
          "lines below list, and nothing else\n")       # earlier versions listed nothing
_recorded = set()       # (marker, entry) pairs this process has written: each once
_TEMPORARY = re.compile(r"^\.(.+)\.[a-z0-9_]{8}(\.[^.]*)?$")   # atomic's: .NAME.XXXXXXXX.SUFFIX


def file_mode():
    """0666 less the process's umask (read without changing it for good)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


@contextmanager
def atomic(path):
    """Yield a temporary path beside `path`; on success it replaces `path` (with the umask's
    mode), on failure it is removed. For writers that want a file name (meshio, h5py, numpy,
    matplotlib)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, file_mode())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    record(path)


def mark(folder):
    """Make `folder` a results folder of the project: its marker, with an empty list."""
    marker = Path(folder).absolute() / MARKER
    _recorded.difference_update({e for e in _recorded if e[0] == marker})   # a folder made anew
    with atomic(marker) as tmp:
        tmp.write_text(HEADER)


def record(path):
    """Add `path` (a file or a whole folder the project wrote) to the list of the nearest
    results folder above it, if any."""
    path = Path(path).absolute()
    for folder in path.parents:
        marker = folder / MARKER
        if marker.is_file():
            entry = path.relative_to(folder).as_posix()
            if entry != MARKER and (marker, entry) not in _recorded:
                with open(marker, "a") as f:      # appends are whole lines, even from two processes
                    f.write(entry + "\n")
                _recorded.add((marker, entry))
            return


def lists_its_files(folder):
    """The marker of results folder `folder` lists what the project wrote (an earlier
    version's did not)."""
    return (Path(folder) / MARKER).read_text().startswith(HEADER)


def unrecorded(folder):
    """The files under results folder `folder` (paths relative to it) that no marker in it
    lists: the project did not write them. The temporary file of a listed file (atomic's,
    left by a run killed as it wrote) counts as the project's."""
    folder = Path(folder)
    found, lists = [], {}
    for here, dirs, files in os.walk(folder):
        here = Path(here)
        if MARKER in files:
            lists[here] = set((here / MARKER).read_text().splitlines()[1:]) | {MARKER}
        root = next((p for p in (here, *here.parents) if p in lists), None)
        for name in files:
            rel = (here / name).relative_to(root or here)
            temporary = _TEMPORARY.match(name)
            if temporary:
                rel = rel.with_name(temporary[1])
            if root is None or not any(p.as_posix() in lists[root]
                                       for p in (rel, *rel.parents[:-1])):
                found.append((here / name).relative_to(folder).as_posix())
    return sorted(found)


def cache_folder(name):
    """The folder `name` of the project's cache, made if missing: under $DEM_FEM_CACHE, else
    (unset or empty) ~/.cache/yade-fenicsx-coupling; never the working folder. ValueError (one
    line) if it cannot be made or written."""
    root = Path(os.environ.get("DEM_FEM_CACHE") or Path.home() / ".cache" / "yade-fenicsx-coupling")
    path = root / name
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ValueError(f"cache folder {path} (DEM_FEM_CACHE) cannot be made: "
                         f"{err.strerror}") from None
    if not os.access(path, os.W_OK):
        raise ValueError(f"cache folder {path} (DEM_FEM_CACHE) is not writable")
    return path


def read_text(path, what="file"):
    """The UTF-8 text of an input file; ValueError naming the file, the byte, its position
    (line, column) when it is not UTF-8, FileNotFoundError when it is missing."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{what} {path} is a folder, not a file")
    if not path.is_file():
        raise FileNotFoundError(f"{what} {path} not found")
    data = path.read_bytes()
    bom = b"\xef\xbb\xbf"                # some editors start UTF-8 files with it
    try:
        return data[len(bom):].decode("utf-8") if data.startswith(bom) else data.decode("utf-8")
    except UnicodeDecodeError as e:
        at = e.start + (len(bom) if data.startswith(bom) else 0)
        line = data.count(b"\n", 0, at) + 1
        column = at - (data.rfind(b"\n", 0, at) + 1) + 1
        raise ValueError(f"{what} {path} is not UTF-8 text: byte 0x{data[at]:02x} at "
                         f"position {at} (line {line}, column {column})") from None


def write_text(path, text):
    with atomic(path) as tmp:
        tmp.write_text(text)


def write_bytes(path, data):
    with atomic(path) as tmp:
        tmp.write_bytes(data)


def write_json(path, obj):
    write_text(path, json.dumps(obj, indent=2, sort_keys=True, default=_jsonable) + "\n")


def write_csv(path, header, rows, fmt="{:.9e}"):
    """A CSV of numbers: `header` (names), `rows` (2D array-like), each value in `fmt`."""
    lines = [",".join(header)] + [",".join(fmt.format(v) for v in row) for row in rows]
    write_text(path, "\n".join(lines) + "\n")


def write_toml(path, data, comment=None):
    import tomli_w
    head = f"# {comment}\n" if comment else ""
    write_text(path, head + tomli_w.dumps(data))


def save_npz(path, **arrays):
    import numpy as np
    with atomic(path) as tmp:
        with open(tmp, "wb") as f:       # a file object: numpy would append ".npz" to a name
            np.savez(f, **arrays)


def save_figure(fig, path, dpi=120):
    """A matplotlib figure as a PNG, then closed."""
    import matplotlib.pyplot as plt
    with atomic(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    plt.close(fig)


def _jsonable(x):
    import numpy as np
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, Path):
        return str(x)
    raise TypeError(f"not JSON-serialisable: {type(x).__name__}")
