"""A user's unmodified YADE script, run in this process for its scene set-up, then made ready
to be coupled.

`run_script` executes the script as YADE's launcher does (`yade script.py`): with the
launcher's namespace (`from yade import *`, `yade.utils`, `yade.pack`, `math`), `sys.argv` =
[script, *args], in a fresh module that becomes `__main__` (YADE runs `PyRunner` commands there).
While it runs, the calls that would start YADE's own loop or wait for a GUI are neutralised
(`O.run`, `O.wait`, `waitIfBatch`, `yade.plot.plot`): the caller drives the time loop with
`O.step()` in its own thread (`O.run` steps in a worker thread, bad for PETSc and MPI). `O.step()`
calls in the script do run (a script may step once to create its cohesive links).

`prepare_dynamics` then refuses what cannot be coupled (periodic cell, no single
NewtonIntegrator) and fixes what explicit coupled dynamics needs, with a warning each: no
numerical damping, fixed time step. `insert_after_newton` puts a Python step right after
NewtonIntegrator in the engine list: the place where a correction of positions and half-step
velocities keeps the leap-frog exact (docs/method.md), before any of the script's
own engines after Newton (recorders, CpmStateUpdater, PyRunners) read the state.
"""
import builtins
import sys
import types
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from yade_side import import_yade

LAUNCHER_NAMESPACE = ("from yade import *\nfrom yade import utils, pack, geom\n"
                      "from yade.utils import *\nfrom yade.pack import *\nfrom math import *\n")


class ScriptRefused(ValueError):
    """The script's scene is one the orchestrator cannot couple; the message says why."""


class ScriptError(ValueError):
    """The script cannot be read or run, or stopped with an error; the message names the
    script and the line."""


@dataclass
class ScriptScene:
    path: Path
    namespace: dict
    dt_from_script: float = None     # O.dt if the script set it
    run_requests: list = field(default_factory=list)   # arguments of neutralised O.run calls
    warnings: list = field(default_factory=list)


def run_script(path, args=()):
    """Reset YADE's scene and run the script's set-up; returns a ScriptScene."""
    path = Path(path).resolve()
    if not path.is_file():
        raise FileNotFoundError(f"YADE script {path} not found")
    yade = import_yade()
    O = yade.Omega()
    O.reset()
    default_dt = O.dt
    module = types.ModuleType("__main__")
    module.__file__ = str(path)
    module.__builtins__ = builtins     # YADE's labels assign `__builtins__.label = engine`
    namespace = vars(module)
    exec(LAUNCHER_NAMESPACE, namespace)
    scene = ScriptScene(path, namespace)
    namespace["waitIfBatch"] = lambda: None
    namespace["exit"] = namespace["quit"] = _exit    # site's would close stdin too
    from common.files import read_text
    try:
        code = compile(read_text(path, "YADE script"), str(path), "exec")
    except SyntaxError as e:
        raise ScriptError(f"YADE script {path}, line {e.lineno}: syntax error: {e.msg}") from None
    # YADE runs PyRunner commands in __main__: the script's module is __main__ from now on,
    # as under YADE's launcher (the orchestrator's own __main__ keeps running unaffected)
    sys.modules["__main__"] = module
    with _neutralised(yade, scene), _argv([str(path), *args]):
        try:
            exec(code, namespace)
        except SystemExit as e:
            _exited(scene, e)
        except Exception as e:
            raise ScriptError(f"YADE script {path}, line {_line(e, path)}: "
                              f"{type(e).__name__}: {one_line(str(e))}") from None
    if O.dt != default_dt:
        scene.dt_from_script = O.dt
    return scene


def current_scene():
    """The scene a script running under YADE's own launcher has built (`yade script.py`,
    whose sys.argv[0] is the script): a ScriptScene for it, with the script's O.dt."""
    import __main__
    return ScriptScene(Path(sys.argv[0]), vars(__main__), dt_from_script=import_yade().Omega().dt)


def _exit(code=None):
    raise SystemExit(code)


def _exited(scene, e):
    """exit(), quit() or sys.exit(0) end the script's set-up where they are, as they end
    `yade script.py` (its last line, in most scripts); the orchestrator then runs the time
    loop. Any other code is the script reporting a failure: an error."""
    where = f"YADE script {scene.path}, line {_line(e, scene.path)}"
    if e.code not in (None, 0):
        raise ScriptError(f"{where}: the script stopped with exit code {e.code!r}") from None
    _warn(scene, f"{where}: exit() ends the script's set-up there; the orchestrator runs "
                 f"the time loop")


def _line(error, path):
    """The line of `path` where `error` was raised (its last frame in that file)."""
    import traceback
    lines = [f.lineno for f in traceback.extract_tb(error.__traceback__)
             if f.filename == str(path)]
    return lines[-1] if lines else "?"


def one_line(text):
    """A message on one line: YADE's PyRunner errors span many (command, error, trace)."""
    return " ".join(text.split())


def step_error(error):
    """One line for an exception out of O.step(): YADE wraps a PyRunner's error as
    "PyRunner error. COMMAND: ... ERROR: ... STACK TRACE: ..."; say which command raised what,
    and the last script line of the trace."""
    text = str(error)
    if "PyRunner error." not in text:
        return f"{type(error).__name__}: {one_line(text)}"
    import re
    command = re.search(r"COMMAND:\s*'(.*?)'", text)
    head, _, trace = text.partition("STACK TRACE:")
    message = re.search(r"ERROR:\s*(.*)", head, re.S)
    lines = [line.strip() for line in trace.splitlines() if line.strip()]
    raised = lines[-1] if lines else one_line(message.group(1) if message else head)
    frames = re.findall(r'File "([^"<]+)", line (\d+)', trace)
    where = f" ({frames[-1][0]}, line {frames[-1][1]})" if frames else ""
    return f"the PyRunner {command.group(1) if command else '?'!r} raised {raised}{where}"


@contextmanager
def _neutralised(yade, scene):
    import yade.plot
    omega = yade.wrapper.Omega
    saved = (omega.run, omega.wait, yade.plot.plot)
    omega.run = lambda self, *a, **k: scene.run_requests.append((a, k))
    omega.wait = lambda self, *a, **k: None
    yade.plot.plot = lambda *a, **k: None
    try:
        yield
    finally:
        omega.run, omega.wait, yade.plot.plot = saved


@contextmanager
def _argv(argv):
    saved = sys.argv
    sys.argv = argv
    try:
        yield
    finally:
        sys.argv = saved


def _warn(scene, message):
    scene.warnings.append(message)
    warnings.warn(message, stacklevel=3)


def prepare_dynamics(scene):
    """Refuse a periodic cell or an engine list without exactly one NewtonIntegrator; set
    Newton's damping to 0 and O.dynDt to False (each with a warning when it was not).
    Returns the NewtonIntegrator."""
    yade = import_yade()
    O = yade.Omega()
    if O.periodic:
        raise ScriptRefused(f"{scene.path.name}: the scene has a periodic cell; the bridging "
                            f"domain needs fixed positions in space, so it cannot be coupled")
    newtons = [e for e in O.engines if isinstance(e, yade.wrapper.NewtonIntegrator)]
    if len(newtons) != 1:
        raise ScriptRefused(f"{scene.path.name}: the engine list has {len(newtons)} "
                            f"NewtonIntegrator engines; coupling needs exactly one")
    newton = newtons[0]
    if newton.damping != 0:
        _warn(scene, f"{scene.path.name}: NewtonIntegrator damping was {newton.damping:g}; set "
                     f"to 0 (numerical damping would break the coupled central differences)")
        newton.damping = 0.0
    if O.dynDt:
        _warn(scene, f"{scene.path.name}: O.dynDt was on; turned off (the coupling needs a "
                     f"fixed time step)")
        O.dynDt = False
    if any(newton.gravity):
        _warn(scene, f"{scene.path.name}: gravity {tuple(newton.gravity)} acts on the spheres "
                     f"only; the FE model has no body force")
    _guard_pyrunners(scene.namespace)
    return newton


class _PyRunnerGuard:
    """Runs a script's PyRunner command as YADE would (in the script's namespace) and keeps
    its first error for `pyrunner_failure`, instead of letting YADE print a traceback."""

    def __init__(self, namespace):
        self.namespace, self.failure = namespace, None

    def __call__(self, command):
        try:
            exec(command, self.namespace)
        except Exception as e:
            if self.failure is None:
                import traceback
                frames = [f for f in traceback.extract_tb(e.__traceback__)
                          if f.filename != __file__]
                where = f" ({frames[-1].filename}, line {frames[-1].lineno})" if frames else ""
                self.failure = (f"the PyRunner {command!r} raised {type(e).__name__}: "
                                f"{one_line(str(e))}{where}")


_guards = []      # weak: the script's namespace holds its guard, nothing else should


def _guard_pyrunners(namespace):
    """Route the script's PyRunner commands through a _PyRunnerGuard."""
    import weakref
    yade = import_yade()
    guard = _PyRunnerGuard(namespace)
    namespace["_pyrunner_guard"] = guard
    _guards[:] = [weakref.ref(guard)]
    for e in yade.Omega().engines:
        if isinstance(e, yade.wrapper.PyRunner) and not e.command.startswith("_pyrunner_guard("):
            e.command = f"_pyrunner_guard({e.command!r})"


def pyrunner_failure():
    """The error of a script's PyRunner since the last call (one line), or None."""
    for ref in _guards:
        guard = ref()
        if guard is not None and guard.failure:
            failure, guard.failure = guard.failure, None
            return failure
    return None


def body_table():
    """Every body: ids, positions (n, 3), radius (NaN if not a sphere), clump (member of a
    clump or a clump), dynamic. A Python loop over bodies: for set-up only."""
    yade = import_yade()
    rows = []
    for b in yade.Omega().bodies:
        if b is None:
            continue
        is_sphere = isinstance(b.shape, yade.wrapper.Sphere)
        rows.append((b.id, *b.state.pos, b.shape.radius if is_sphere else np.nan,
                     b.isClump or b.isClumpMember, b.dynamic))
    a = np.array(rows, float).reshape(-1, 7)
    return {"ids": a[:, 0].astype(int), "pos": a[:, 1:4], "radius": a[:, 4],
            "clump": a[:, 5].astype(bool), "dynamic": a[:, 6].astype(bool)}


def insert_after_newton(callback, label="coupling_step"):
    """Insert a PyRunner calling `callback()` every step right after NewtonIntegrator (YADE
    also makes `label` a builtin name for the engine, as for any labelled engine)."""
    yade = import_yade()
    import __main__
    O = yade.Omega()
    name = f"_{label}"
    setattr(__main__, name, callback)
    engines = list(O.engines)
    i = next(k for k, e in enumerate(engines) if isinstance(e, yade.wrapper.NewtonIntegrator))
    runner = yade.wrapper.PyRunner(command=f"{name}()", iterPeriod=1, initRun=True, label=label)
    O.engines = engines[:i + 1] + [runner] + engines[i + 1:]
    return runner
