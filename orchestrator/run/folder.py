"""Results folders, shared by every command. A folder the project makes carries a marker
file; `--force` replaces only such a folder, never one the project did not write."""
import shutil
from pathlib import Path

MARKER = ".yade-fenicsx-results"


class ResultsExist(RuntimeError):
    pass


def check_out(path, force=False):
    """Refuse an existing non-empty folder unless `force` and it is a results folder of the
    project (its marker); True when it would be replaced."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise ResultsExist(f"--out {out} is a file, not a folder")
    if out.exists() and any(out.iterdir()):
        if not force:
            raise ResultsExist(f"results folder {out} exists and is not empty; "
                               f"choose another --out or pass --force to replace it")
        if not (out / MARKER).is_file():
            raise ResultsExist(f"results folder {out} was not written by this project (no "
                               f"{MARKER} in it): --force replaces only the project's own "
                               f"results folders; choose another --out")
        return True
    return False


def prepare_out(path, force=False):
    """Create the run folder `path` with its marker; refuse an existing non-empty one unless
    `force` (and it is one of the project's)."""
    from common.files import write_text
    out = Path(path)
    if check_out(out, force):
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / MARKER, "results folder written by yade-fenicsx-coupling; "
                             "`--force` may replace it\n")
    return out


def start_folder(case, out, force=False):
    """prepare_out, then `case.toml`: the case as run (defaults filled in, --set applied,
    paths absolute), which runs again as it is."""
    from common.files import write_toml
    out = prepare_out(out, force)
    write_toml(out / "case.toml", case.data, comment=f"the case as run, from {case.path.resolve()}")
    return out
