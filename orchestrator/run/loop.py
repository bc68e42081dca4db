"""The run loop shared by every case: it steps a model (orchestrator.contracts.RunModel) and
tells the recorder when to sample, check, output and checkpoint; at the end it writes the
results (orchestrator.run.outputs)."""
import logging
from contextlib import contextmanager
from dataclasses import dataclass

from orchestrator.casefile import MAX_STEPS

log = logging.getLogger("orchestrator.run")
log.propagate = False      # run.log only: the console has the progress bar and the summary


class StepFailed(RuntimeError):
    """A step raised (e.g. a script's PyRunner): one line; the whole message is in run.log."""


@dataclass
class Schedule:
    steps: int
    sample_every: int = 5         # sensor histories
    check_every: int = 50         # energy, blow-up guard, progress bar
    output_every: int = 200       # ParaView frames and damage maps
    checkpoint_every: int = 1000  # checkpoints (orchestrator.run.restart)

    def __post_init__(self):
        for name in ("steps", "sample_every", "check_every", "output_every", "checkpoint_every"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if self.steps > MAX_STEPS:
            raise ValueError(f"steps must be at most {MAX_STEPS:.0e}, got {self.steps!r}")


def run(model, schedule, out, title, reference_energy, info=None, arrays=None, checks=None,
        notes=(), quiet=False, resume=False, inputs=None):
    """Run `model` for schedule.steps and write its results folder `out` (already prepared).

    info: entries put first in summary.json; arrays: extra entries of damage.npz (or a
    function that gives them at the end); inputs:
    what the results depend on (orchestrator.run.inputs), kept in checkpoints and compared
    on resume;
    checks(final_damage, fe_peak) -> warnings (fe_peak: outputs.fe_peak, None without FE);
    notes: set-up remarks for the log; resume: carry on
    from the checkpoint in `out`. Checkpoints every schedule.checkpoint_every steps and when
    SIGTERM asks the run to stop (then raises restart.Stopped). Returns the summary.
    """
    from orchestrator.run import outputs, restart
    from orchestrator.run.record import Recorder
    from yade_side import yade_threads
    m = model
    with _run_log(out):
        log.info("%s: %d spheres, %d FE nodes, %d bridging spheres, dt %.4g s (critical %s), "
                 "%d steps", title, m.sphere_count(), 0 if m.fe is None else len(m.fe.nodes),
                 len(m.bridge_index), m.dt, m.critical, schedule.steps)
        threads = yade_threads()
        if threads > 1:
            log.info("note: YADE on %d threads: results reproducible to round-off only "
                     "(--threads 1 for bit-identical results and restarts)", threads)
        for note in notes:
            log.info("note: %s", note)
        meta = {**restart.fingerprint(m, title, schedule.steps), "info": info or {},
                "inputs": inputs or {}, "yade_threads": threads}
        recorder = Recorder(m, out, meta, reference_energy, log, resume)
        _loop(m, schedule, recorder, title, quiet)
        wall = recorder.finish()
        peak = None if m.fe is None else outputs.fe_peak(recorder.rec)
        warnings = list(checks(recorder.rec.maps[-1], peak)) if checks else []
        summary = outputs.summary(m, recorder.rec, schedule, wall, recorder.seconds(),
                                  warnings, info, recorder.qoi)
        outputs.write_results(out, title, m, recorder.rec, summary,
                              arrays() if callable(arrays) else arrays, recorder.qoi)
        for w in warnings:
            log.warning(w)
            print(f"WARNING: {w}")
        log.info("done: %d steps in %.3g s (%.3g ms/step)", schedule.steps, wall,
                 1e3 * wall / schedule.steps)
        return summary


def _loop(m, schedule, recorder, title, quiet):
    from orchestrator.run import restart
    from orchestrator.run.progress import progress
    from yade_side.user_script import pyrunner_failure, step_error
    s, rec = schedule, recorder.rec
    with restart.StopRequest() as stop, progress(s.steps, title, quiet, initial=rec.n) as bar:
        for n in range(rec.n + 1, s.steps + 1):
            try:
                m.step()
            except RuntimeError as e:           # YADE's errors, a PyRunner's among them
                log.error("step %d raised:\n%s", n, e)
                raise StepFailed(f"step {n}: {step_error(e)}") from None
            failure = pyrunner_failure()
            if failure:
                raise StepFailed(f"step {n}: {failure}")
            t = n * m.dt
            if n % s.sample_every == 0:
                recorder.sample(t)
            if n % s.check_every == 0 or n == s.steps:
                bar.set_postfix(**recorder.check(n, t), refresh=False)
            if n % s.output_every == 0 or n == s.steps:
                recorder.output(t)
            bar.update()
            if recorder.checkpoints and n < s.steps and (
                    stop.requested or n % s.checkpoint_every == 0):
                recorder.checkpoint(n)
            if stop.requested and n < s.steps:
                how = (f"resume with --resume {recorder.out}" if recorder.checkpoints else
                       f"no checkpoint ({recorder.no_checkpoints})")
                raise restart.Stopped(f"stopped at step {n} of {s.steps}: {how}", stop.signum)


@contextmanager
def _run_log(out):
    """run.log in the results folder for the run's duration; errors are logged too."""
    from common.files import record
    handler = logging.FileHandler(out / "run.log")
    record(out / "run.log")
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
    log.addHandler(handler)
    log.setLevel(logging.INFO)
    try:
        yield
    except Exception as e:
        log.error("run stopped: %s", e)
        raise
    finally:
        log.removeHandler(handler)
        handler.close()
