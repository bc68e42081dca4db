"""Results folders, shared by every command. A folder the project makes carries a marker
file that lists what the project wrote in it (common.files); `--force` replaces only such a
folder, and only when the list holds every file in it: never a folder or a file the project
did not write, never the current folder or one above it, never one that holds an input of
the run. Commands check the
folder (`check_out`) before the slow work and make it (`prepare_out`) once every input is
validated. A command that fails leaves no folder holding only its marker, and marks the
others it made failed (`FAILED`, the error), keeping what the run wrote for the diagnosis."""
import os
import shutil
import tempfile
from pathlib import Path

from common.files import MARKER, lists_its_files, mark, unrecorded

FAILED = "FAILED"

_made = []    # folders prepare_out made in this process (for settle_failure)


class ResultsExist(RuntimeError):
    pass


def check_out(path, force=False, inputs=()):
    """Refuse a folder the run cannot write, or an existing non-empty one unless `force` and it
    is a results folder of the project (its marker) holding none of `inputs` (the run's input
    files or folders); True when it would be replaced."""
    out = Path(path)
    where = out.resolve()
    here = Path.cwd().resolve()
    if where == here or where in here.parents:
        raise ResultsExist(f"--out {path}: the current folder or one above it cannot be a "
                           f"results folder; give a new folder")
    if out.exists() and not out.is_dir():
        raise ResultsExist(f"--out {path} is a file, not a folder")
    _writable(out)
    if out.exists() and any(out.iterdir()):
        if not force:
            raise ResultsExist(f"results folder {path} exists and is not empty; "
                               f"choose another --out or pass --force to replace it")
        if not (out / MARKER).is_file():
            raise ResultsExist(f"results folder {path} was not written by this project (no "
                               f"{MARKER} in it): --force replaces only the project's own "
                               f"results folders; choose another --out")
        if out.is_symlink():
            raise ResultsExist(f"--out {path} is a symbolic link: --force replaces only a "
                               f"folder itself; give the folder it points to")
        for item in inputs:
            item = Path(item).resolve()
            if item == where or where in item.parents:
                raise ResultsExist(f"--out {path} holds {item}, an input of this run: --force "
                                   f"would delete it; choose another --out")
        foreign = unrecorded(out)
        if foreign and not lists_its_files(out):
            raise ResultsExist(f"results folder {path} was written by an earlier version, which "
                               f"did not list its files: --force cannot tell them from yours; "
                               f"delete it yourself or choose another --out")
        if foreign:
            shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5
                                              else "")
            raise ResultsExist(f"results folder {path} holds {len(foreign)} file(s) the project "
                               f"did not write ({shown}): --force replaces only what it wrote; "
                               f"move them out or choose another --out")
        return True
    return False


def _writable(out):
    """Refuse `out` when it lies under a file or its nearest existing folder takes no new file
    (read-only folder or file system, no permission): found now, not after the model is built."""
    existing = out.absolute()
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise ResultsExist(f"--out {out}: {existing} is a file, not a folder")
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as e:
        raise ResultsExist(f"--out {out}: cannot write in {existing} "
                           f"({e.strerror or e})") from None


def prepare_out(path, force=False, inputs=()):
    """Create the run folder `path` with its marker; refuse as check_out does. Call it once
    every input is validated: with `force` it replaces an earlier results folder."""
    out = Path(path)
    if check_out(out, force, inputs):
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    mark(out)
    _made.append(out)
    return out


def start_folder(case, out, force=False):
    """prepare_out, then `case.toml`: the case as run (defaults filled in, --set applied,
    paths absolute), which runs again as it is."""
    from common.files import write_toml
    out = prepare_out(out, force, input_files(case))
    write_toml(out / "case.toml", case.data, comment=f"the case as run, from {case.path.resolve()}")
    return out


def input_files(case):
    """The files a case reads: the case file, a script, a mesh (for check_out)."""
    d = case.data
    files = [case.path, d.get("de", {}).get("script"), d.get("fe", {}).get("mesh")]
    return [Path(f) for f in files if f and f != "box"]


def settle_failure(error):
    """After a command failed with `error`: remove the folders it made that hold only their
    marker, and write FAILED (the error) into the others; forget them."""
    from common.files import write_text
    while _made:
        out = _made.pop()
        if not out.is_dir():
            continue
        if [p.name for p in out.iterdir()] == [MARKER]:
            shutil.rmtree(out)
        else:
            write_text(out / FAILED, f"{error}\n")


def forget():
    """A command ended well (or stopped with a checkpoint): its folders stay as they are."""
    _made.clear()


def resume_folder(out):
    """A resumed run carries on in `out`: no longer a failed folder, marked again if it fails."""
    try:
        os.unlink(Path(out) / FAILED)
    except FileNotFoundError:
        pass
    _made.append(Path(out))
