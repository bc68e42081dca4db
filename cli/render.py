"""Pictures of a run's folder with ParaView: finds pvpython, checks the folder, and runs
cli/paraview_render.py under `xvfb-run -a pvpython` (this ParaView build needs an X
display even to render offscreen; a virtual one is started per call). `xvfb-run -a` takes the
first free display number from its start, which races with other users' X servers starting at
the same moment: the search starts at a number of this process's own, and a run whose display
could not be opened is tried once more.

The cut goes through the run's `under_impact` sensor when it has one (the slab cases and
block_impact do), else through the centre of the model.
"""
import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from orchestrator.run.folder import prepare_out

SCRIPT = Path(__file__).with_name("paraview_render.py")
X_FAILED = ("CreateAWindow", "bad X server connection", "Xvfb failed to start")
INSTALL = ("install ParaView with `make setup-paraview` (Debian: apt-get install "
           "python3-paraview xvfb xauth)")


def pvpython_command():
    """The command that runs a pvpython script offscreen, or a ValueError saying how to
    install what is missing."""
    pvpython = shutil.which("pvpython")
    if pvpython is None:
        raise ValueError(f"render: pvpython not found; {INSTALL}")
    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        raise ValueError(f"render: xvfb-run not found (pvpython needs an X display); {INSTALL}")
    return [xvfb, "-a", "-n", str(100 + os.getpid() % 800), pvpython]


def cut_point(run_dir):
    """The point the pictures' cut goes through, or None (the model's centre); a ValueError
    if `run_dir` is not a run's folder."""
    run_dir = Path(run_dir)
    summary = run_dir / "summary.json"
    series = [run_dir / n for n in ("spheres.pvd", "fe.xdmf") if (run_dir / n).is_file()]
    if not summary.is_file() or not series:
        raise ValueError(f"render: {run_dir} is not a run's folder (it needs summary.json and "
                         f"spheres.pvd or fe.xdmf)")
    try:
        sensors = json.loads(summary.read_text()).get("sensors", {})
    except json.JSONDecodeError as e:
        raise ValueError(f"render: {summary} is not valid JSON ({e})") from None
    impact = sensors.get("under_impact", {}).get("position")
    return [float(x) for x in impact] if impact else None


def render(run_dir, out, times=None, animate=False, force=False):
    """PNG pictures of the run in `out` at the frames nearest `times` (s; default a third,
    two thirds and the end), and out/animation.avi over every frame if `animate`.
    Returns [(file, [frame times it shows])]."""
    cut = cut_point(run_dir)
    command = pvpython_command()
    if times is not None and any(t < 0 for t in times):
        raise ValueError(f"render: --times must be >= 0, got {times}")
    out = prepare_out(out, force, inputs=[run_dir])
    job = {"run": str(Path(run_dir).resolve()), "out": str(out.resolve()), "times": times,
           "cut": cut, "animate": bool(animate)}
    with tempfile.TemporaryDirectory() as tmp:
        job_file = Path(tmp) / "job.json"
        job_file.write_text(json.dumps(job))
        for attempt in range(2):
            proc = subprocess.run(command + [str(SCRIPT), str(job_file)], capture_output=True,
                                  text=True, env={**os.environ, "PYTHONPATH": ""})
            if not any(sign in proc.stderr for sign in X_FAILED):
                break
    written = [json.loads(line) for line in proc.stdout.splitlines()
               if line.startswith('{"file"')]
    if proc.returncode != 0 or not written:
        last = [line for line in proc.stderr.splitlines() if line.strip()][-1:]
        raise ValueError(f"render: ParaView failed on {run_dir} (exit code {proc.returncode})"
                         f"{': ' + last[0].strip() if last else ''}")
    return [(Path(w["file"]), w["times"]) for w in written]
