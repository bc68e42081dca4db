"""Runs on YADE's MPI (yade_side.distributed): a command given `--mpi N` (or a case's
slab.mpi) starts itself again under `mpiexec -n N`, where rank 0 runs it and the other ranks
own the spheres."""

RANK_MEMORY = 0.25e9     # bytes: a rank's process with YADE and MPI, before its spheres (249 MB)


def check_machine(ranks, runs=1):
    """Refuse (ValueError, one line) `runs` MPI runs of `ranks` each at once that this machine
    cannot hold, before mpiexec starts: each rank but rank 0 (which drives) needs a core of its
    own, and each RANK_MEMORY of the memory available."""
    from yade_side import cores
    workers, have = runs * (ranks - 1), cores()
    where = f"{runs} runs × --mpi {ranks}" if runs > 1 else f"--mpi {ranks}"
    if workers > have:
        raise ValueError(f"{where}: {workers} workers (every rank but rank 0, which drives) on "
                         f"{have} cores: at most {have // runs + 1} ranks per run here")
    free = _available_memory()
    if free is not None and runs * ranks * RANK_MEMORY > free:
        raise ValueError(f"{where}: {runs * ranks} processes need "
                         f"{runs * ranks * RANK_MEMORY / 1e9:.1f} GB or more, "
                         f"{free / 1e9:.1f} GB are available")


def _available_memory():
    """MemAvailable of /proc/meminfo (bytes), None where there is none."""
    try:
        for line in open("/proc/meminfo"):
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def on_ranks(ranks, args):
    """In one process: this command again under mpiexec, its exit code. Under mpiexec: None on
    rank 0 (which goes on with the command), 0 on the others once they have served."""
    import shutil
    launcher = shutil.which("mpiexec")
    if launcher is None:        # (Open MPI's mpi4py cannot even start without it)
        raise ValueError(f"--mpi {ranks}: no mpiexec on PATH (Debian package openmpi-bin; "
                         f"`make setup` installs it)")
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    if comm.size == 1:
        check_machine(ranks)
        return _mpiexec(launcher, ranks, args)
    if comm.size != ranks:
        raise ValueError(f"--mpi {ranks} under mpirun -n {comm.size}: give the same count, or "
                         f"run without mpirun (the command starts mpiexec itself)")
    if comm.rank == 0:
        from yade_side.distributed import release_workers_at_exit
        release_workers_at_exit()
        return None
    from yade_side import import_yade
    from yade_side.distributed import serve
    import_yade(args.threads or 1)
    serve()
    return 0


def _mpiexec(launcher, ranks, args):
    import shutil
    import signal
    import subprocess
    import sys
    # each rank on one YADE thread unless --threads says otherwise; root may run it (containers)
    env = dict(environment_without_mpi(), OMP_NUM_THREADS=str(args.threads or 1),
               OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    # mpiexec in a session of its own: Ctrl-C in a terminal reaches this process only, not
    # mpiexec as well (which, signalled twice, kills the ranks before rank 0 can say why);
    # and told to end when this process dies, however it dies (util-linux's setpriv sets
    # Linux's parent-death signal: no Python runs between fork and exec)
    setpriv = shutil.which("setpriv")
    ends = [setpriv, "--pdeathsig", "TERM"] if setpriv else []
    proc = subprocess.Popen([*ends, launcher, "--oversubscribe", "-n", str(ranks),
                             sys.executable, "-m", "cli", *args.argv], env=env,
                            start_new_session=True)
    # a stop asked of this process goes to the run as SIGTERM (mpiexec passes it on to every
    # rank: rank 0 ends its step and says why, the workers ignore it), and its exit code says
    # so as a one-process run's would
    asked = []

    def forward(signum, _frame):
        asked.append(signum)
        proc.send_signal(signal.SIGTERM)
    previous = {s: signal.signal(s, forward) for s in (signal.SIGTERM, signal.SIGINT)}
    try:
        code = proc.wait()
        return 128 + asked[0] if asked and code else code
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


# what Open MPI's MPI_Init sets in a process's environment: a child that inherits it joins
# that process's MPI, and an mpiexec it starts fails without a word (exit 1)
_MPI_STATE = ("PMIX_", "ORTE_", "OMPI_MCA_ess", "OMPI_MCA_pmix", "OMPI_MCA_orte_", "OMPI_APP_",
              "OMPI_COMM_WORLD_", "OMPI_UNIVERSE_", "OMPI_FIRST_", "OMPI_FILE_")


def environment_without_mpi():
    """The environment for a process that starts MPI of its own: os.environ (what MPI_Init
    sets in C in this process stays out of it) less the MPI state it inherited from a parent
    that had started MPI."""
    import os
    return {k: v for k, v in os.environ.items() if not k.startswith(_MPI_STATE)}


def case_ranks(case):
    """A slab case's slab.mpi (0 for other kinds): its full model on YADE's MPI."""
    if case.kind != "slab":
        return 0
    from cases.slab.casefile import spec
    from cases.slab.model import check_ranks
    slab = spec(case)
    try:
        check_ranks(slab, case["slab"]["model"])
    except ValueError as e:
        raise ValueError(f"{case.path}: {e}") from None
    return slab.mpi
