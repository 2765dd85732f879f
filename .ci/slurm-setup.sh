#!/usr/bin/env bash
# A single-node SLURM cluster on this machine, for the test of `hydra/launcher=slurm`
# (tests/tasks/test_launchers.py; docs/operations.md, "Clusters"). Run as root; idempotent: it
# installs Debian's slurm-wlm and munge if missing, writes /etc/slurm/slurm.conf for this host,
# starts munged, slurmctld and slurmd unless they run, and waits until the node takes jobs. A
# slurm.conf it did not write is never overwritten: that cluster is used if it takes jobs.
#
# No systemd is needed: the daemons start by hand. No cgroups either: process tracking by the
# process tree (proctrack/linuxproc), no task containment (task/none), so it also runs in a
# container. Prints one line and exits non-zero if the cluster does not come up.
set -euo pipefail

fail() { echo "slurm-setup: $*" >&2; exit 1; }
[ "$(id -u)" -eq 0 ] || fail "needs root (it installs packages and starts daemons)"

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
fi

host="$(hostname -s)"
cpus="$(nproc)"
marker="# Written by .ci/slurm-setup.sh"
if [ -e /etc/slurm/slurm.conf ] && ! head -1 /etc/slurm/slurm.conf | grep -qx "${marker}: one node, this host, for tests."; then
  # A cluster of someone else's: never overwrite its config; use it if it takes jobs.
  sinfo -h -o %T 2>/dev/null | grep -qE '^(idle|mixed)' \
    && { echo "slurm-setup: using the existing cluster (/etc/slurm/slurm.conf not ours)"; exit 0; }
  fail "/etc/slurm/slurm.conf exists and is not ours, and its cluster takes no jobs"
fi
memory_mb="$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)"
mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm /run/munge
cat >/etc/slurm/slurm.conf <<EOF
${marker}: one node, this host, for tests.
ClusterName=grace-ci
SlurmctldHost=${host}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
NodeName=${host} CPUs=${cpus} RealMemory=${memory_mb} State=UNKNOWN
PartitionName=debug Nodes=${host} Default=YES MaxTime=INFINITE State=UP
EOF

if [ ! -s /etc/munge/munge.key ]; then
  dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
fi
chown -R munge:munge /etc/munge /run/munge /var/lib/munge /var/log/munge 2>/dev/null || true
chmod 400 /etc/munge/munge.key
pgrep -x munged >/dev/null || runuser -u munge -- /usr/sbin/munged
munge -n | unmunge >/dev/null || fail "munge does not authenticate (see /var/log/munge/munged.log)"

pgrep -x slurmctld >/dev/null || /usr/sbin/slurmctld
pgrep -x slurmd >/dev/null || /usr/sbin/slurmd
for _ in $(seq 60); do
  state="$(sinfo -h -n "$host" -o %T 2>/dev/null || true)"
  case "$state" in
    idle*|mixed*|allocated*)
      # Our test cluster: jobs left by an interrupted earlier test (restored from the
      # controller's state) would hold the node, and the test's jobs would wait for ever.
      scancel --full --quiet --user "$(id -un)" 2>/dev/null || true
      echo "slurm-setup: node ${host} is ${state} (${cpus} CPUs)"; exit 0 ;;
    down*|drain*) scontrol update NodeName="$host" State=RESUME 2>/dev/null || true ;;
  esac
  sleep 1
done
fail "node ${host} not ready after 60 s (state '${state:-none}'; see /var/log/slurm/*.log)"
