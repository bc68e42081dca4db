"""What a run records as it goes: sensor samples, energy and constraint-gap checks (with the
blow-up guard), damage maps and ParaView frames, checkpoints. The loop calls it; it writes
the series files itself, frame by frame."""
from time import perf_counter

import numpy as np

from orchestrator.run import restart
from orchestrator.run.checks import fe_cells_checked
from orchestrator.run.guard import BlowUpGuard


class Recorder:
    def __init__(self, model, out, meta, reference_energy, log, resume=False):
        from yade_side.output import SphereSeries
        self.m, self.out, self.meta, self.log = model, out, meta, log
        self.guard = BlowUpGuard(reference_energy, growth=2.0)
        growing = hasattr(model, "on_grow")
        from yade_side.distributed import remote
        self.no_checkpoints = ("the FE state is distributed over MPI ranks"
                               if model.fe is not None and model.fe.distributed else
                               "the YADE scene is split over MPI ranks"
                               if remote() is not None else None)
        self.checkpoints = self.no_checkpoints is None
        if not self.checkpoints:
            log.info("no checkpoints: %s", self.no_checkpoints)
        self.fe_read = fe_cells_checked(model)
        if growing:
            model.on_grow.append(self.regrid)
        # the quantities of interest, if the model has them: made before a checkpoint is
        # loaded, so that they read the model's state at t = 0 first
        self.qoi = model.quantities()
        if resume:
            self.rec = restart.load(out, model, meta, self.qoi is not None)
            if self.qoi is not None:
                self.qoi.restore(self.rec.quantity_state)
            log.info("resumed from the checkpoint of step %d", self.rec.n)
        else:
            self.rec = restart.Record(times=[0.0], history=[model.sensor_displacements()],
                                      quantities=[] if self.qoi is None
                                      else [self.qoi.sample()])
        frames = len(self.rec.maps_t)
        self.spheres = SphereSeries(out / "spheres.pvd", frames=frames)
        self.fe_series = None
        if model.fe is not None:
            from fenicsx_side.output import XdmfSeries
            # a grown zone's run goes on in the file of its current FE mesh (regrid)
            self.fe_series = XdmfSeries(out / self.rec.fe_series, model.fe,
                                        frames=frames - self.rec.fe_first)
        self.output_s = 0.0
        self.t_run = perf_counter()
        if not resume:
            self.output(0.0)

    def sample(self, t):
        self.rec.times.append(t)
        self.rec.history.append(self.m.sensor_displacements())
        if self.qoi is not None:
            self.rec.quantities.append(self.qoi.sample())
        if self.m.fe is not None:
            self._fe_peak(t)

    def _fe_peak(self, t):
        """The FE's peak stresses so far, in the cells the checks read (fe_read): the paper's
        check that the FE stays elastic is over the whole run, not its last state (a wave
        passes ft and moves on)."""
        s, peak, read = self.m.fe.stress(), self.rec.fe_peak, self.fe_read
        for k, values in ((0, s.max_principal), (2, s.von_mises)):
            top = float((values if read is None else values[read]).max(initial=0.0))
            if top > peak[k]:
                peak[k:k + 2] = top, t

    def check(self, n, t):
        """Energy, blow-up guard and constraint gap at step n; returns the progress bar's
        postfix."""
        m, rec = self.m, self.rec
        e = m.energy()
        rec.energy.append((t, e))
        checked = {"sensor displacements": rec.history[-1]}
        if m.fe is not None:
            checked["FE displacement"] = m.fe.u
        self.guard.check(n, e, **checked)
        # energy balance: total, and what the coupling put into the FE model and created (+)
        # or dissipated (−) itself
        balance = {}
        if m.stepper is not None and m.stepper.last is not None:
            meter, (pred, corrected) = m.stepper.exchange, m.stepper.last.gaps()
            rec.gaps.append((t, pred, corrected))
            balance = {"to_FE": f"{meter.to_fe:.3g} J", "coupling": f"{meter.net:+.3g} J",
                       "gap": f"{pred:.2g}>{corrected:.2g}"}
        self.log.info("step %d, t = %.6g s, energy %.6g J%s", n, t, e,
                      "".join(f", {k} {v}" for k, v in balance.items()))
        return dict(t=f"{t * 1e3:.4g} ms", E=f"{e:.4g} J", **balance)

    def output(self, t):
        """Damage map and a ParaView frame of both series."""
        t0 = perf_counter()
        s = self.m.spheres
        dmg = self.m.damage.update()
        self.rec.maps_t.append(t)
        self.rec.maps.append(dmg)
        if self.qoi is not None:
            self.qoi.output()
        s.read()
        self.spheres.write(t, s.pos, s.radius, displacement=s.displacement(), velocity=s.vel,
                           rotation_speed=s.angvel, damage=dmg)
        if self.fe_series is not None:
            self.fe_series.write(t)
        self.output_s += perf_counter() - t0

    def regrid(self, old, new, k):
        """The model's DE zone grew (its k-th conversion): the damage maps so far are put on
        its spheres (a sphere new to the DE had none), and the FE series goes on in
        fe-zone{k + 1}.xdmf, the FE part's new mesh (its first frame the next output, which
        a checkpoint records); the checkpoints' fingerprint is the new model's."""
        from orchestrator.run.grow import match
        at = match(old.spheres.ref_pos, new.spheres.ref_pos, 1e-9)
        self.rec.maps = [np.where(at >= 0, m[at], 0.0) for m in self.rec.maps]
        self.meta.update(restart.fingerprint(new, self.meta["title"], self.meta["steps"]))
        if self.qoi is not None:
            self.qoi = new.quantities(self.qoi)
        self.fe_read = fe_cells_checked(new)
        if self.fe_series is not None:
            from fenicsx_side.output import XdmfSeries
            self.fe_series.close()
            self.rec.fe_series, self.rec.fe_first = f"fe-zone{k + 1}.xdmf", len(self.rec.maps_t)
            self.fe_series = XdmfSeries(self.out / self.rec.fe_series, new.fe)

    def seconds(self):
        """Time split of this segment and the earlier ones."""
        return restart.add_splits(self.rec.seconds, {**self.m.seconds, "output": self.output_s})

    def checkpoint(self, n):
        rec = self.rec
        rec.n = n
        if self.qoi is not None:
            rec.quantity_state = self.qoi.state()
        rec.wall_s += perf_counter() - self.t_run
        self.t_run = perf_counter()
        restart.save(self.out, rec, self.m, self.meta, self.seconds())
        self.log.info("checkpoint at step %d", n)

    def finish(self):
        """The run's wall time, all segments; closes the FE series."""
        if self.fe_series is not None:
            self.fe_series.close()
        return self.rec.wall_s + perf_counter() - self.t_run
