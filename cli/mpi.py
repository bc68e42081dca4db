"""Runs on YADE's MPI (yade_side.distributed): a command given `--mpi N` (or a case's
slab.mpi) starts itself again under `mpiexec -n N`, where rank 0 runs it and the other ranks
own the spheres."""


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
    import signal
    import subprocess
    import sys
    # each rank on one YADE thread unless --threads says otherwise; root may run it (containers)
    env = dict(environment_without_mpi(), OMP_NUM_THREADS=str(args.threads or 1),
               OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    proc = subprocess.Popen([launcher, "--oversubscribe", "-n", str(ranks), sys.executable,
                             "-m", "cli", *args.argv], env=env)
    # a stop asked of this process goes to the run (mpiexec passes it on to rank 0, which
    # stops; the workers ignore it), and its exit code says so as a one-process run's would
    asked = []

    def forward(signum, _frame):
        asked.append(signum)
        proc.send_signal(signum)
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
