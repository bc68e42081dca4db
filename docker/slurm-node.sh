#!/usr/bin/env bash
# A single-node Slurm cluster on this machine, to try `batch --slurm` scripts with sbatch:
# munged, slurmctld and slurmd on loopback, one partition of this machine's cores, no cgroups
# (none needed to run jobs; machines without systemd have no delegated cgroup tree).
# Needs the packages of `make setup-slurm`; writes /etc/slurm/slurm.conf; run as root.
#   docker/slurm-node.sh        # start; `sinfo` shows the node idle
#   docker/slurm-node.sh stop
set -euo pipefail
if [ "${1:-}" = stop ]; then
    for pid in /run/slurmd.pid /run/slurmctld.pid /run/munge/munged.pid; do
        [ -f "$pid" ] && kill "$(cat "$pid")" 2>/dev/null || true
    done
    exit 0
fi
node=$(hostname -s)
cpus=$(nproc)
mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm /run/munge
cat > /etc/slurm/slurm.conf <<EOF
ClusterName=single
SlurmctldHost=$node(127.0.0.1)
AuthType=auth/munge
SlurmUser=root
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
chown munge:munge /run/munge
pgrep -x munged >/dev/null || runuser -u munge -- /usr/sbin/munged
pgrep -x slurmctld >/dev/null || slurmctld
pgrep -x slurmd >/dev/null || slurmd
for _ in $(seq 30); do
    [ "$(sinfo -h -o %T 2>/dev/null)" = idle ] && { sinfo; exit 0; }
    sleep 1
done
echo "error: the Slurm node did not come up; see /var/log/slurm/" >&2
exit 1
