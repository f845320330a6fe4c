#!/usr/bin/env bash
# A real one-node Slurm cluster on this machine, and a dgv shot run through it (docs/farm.md):
# munged, slurmctld and slurmd started here as root (no systemd) with a minimal slurm.conf in a
# temporary folder; a 12-frame dynamics shot submitted with `dgv farm submit --chunk 4`; one
# render task cancelled while it runs and `dgv farm resubmit`; then every frame compared byte for
# byte with a plain `dgv render` of the same scene, and the frames of the tasks that were not
# cancelled checked untouched. Every daemon is stopped on any exit, and none may be left.
# Usage: scripts/farm-test.sh   (root; builds dgv with scripts/build.sh unless DGV names a binary)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
if [[ $(id -u) -ne 0 ]]; then echo "farm-test: must run as root (it starts munged, slurmctld and slurmd)" >&2; exit 2; fi
./scripts/install-deps.sh --farm
if [[ -z ${DGV:-} ]]; then ./scripts/build.sh >/dev/null; DGV=$root/${DGV_BUILD_DIR:-build}/dgv; fi
DGV=$(realpath "$DGV")

T=$(mktemp -d /tmp/dgv-farm-test.XXXXXX)
chmod 755 "$T"
pids=()
stop() {
  local rc=$?
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do kill "${pids[i]}" 2>/dev/null || true; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$p" 2>/dev/null || true
    wait "$p" 2>/dev/null || true
  done
  for _ in $(seq 50); do pgrep -x slurmstepd >/dev/null || break; sleep 0.1; done
  left=0
  pgrep -f "$T/" >/dev/null && left=1
  for d in munged slurmctld slurmd slurmstepd; do pgrep -x "$d" >/dev/null && left=1; done  # (one name each: pgrep warns on a pattern over 15 characters)
  if (( left )); then
    echo "farm-test: FAIL: processes left behind:" >&2; pgrep -af "$T/|munged|slurmctld|slurmd|slurmstepd" >&2; rc=1
  fi
  if [[ $rc -ne 0 && -d $T ]]; then
    for f in "$T"/*.log "$T"/shot/farm/logs/*; do [[ -f $f ]] && { echo "--- $f" >&2; tail -20 "$f" >&2; }; done
  fi
  rm -rf "$T"
  exit "$rc"
}
trap stop EXIT
trap 'exit 130' INT TERM
fail() { echo "farm-test: FAIL: $*" >&2; exit 1; }
start=$SECONDS

host=$(hostname -s)
if ! getent hosts "$host" >/dev/null; then
  echo "farm-test: $host does not resolve; adding '127.0.0.1 $host' to /etc/hosts"
  echo "127.0.0.1 $host" >>/etc/hosts
fi

# munge: a fresh key, its own socket.
dd if=/dev/urandom of="$T/munge.key" bs=1024 count=1 status=none
chmod 400 "$T/munge.key"
mkdir -m 755 "$T/munge"
munged -F -f --key-file="$T/munge.key" --socket="$T/munge/socket" --pid-file="$T/munge/pid" \
  --seed-file="$T/munge/seed" --log-file="$T/munged.log" &
pids+=($!)
for _ in $(seq 50); do [[ -S $T/munge/socket ]] && break; sleep 0.1; done
[[ -S $T/munge/socket ]] || fail "munged did not start"

mkdir -p "$T/state" "$T/spool"
export SLURM_CONF=$T/slurm.conf
cat >"$SLURM_CONF" <<EOF
ClusterName=dgvtest
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$T/munge/socket
CredType=cred/munge
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/slurmctld.log
SlurmdLogFile=$T/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerParameters=kill_invalid_depend
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
KillWait=5
MinJobAge=300
NodeName=$host CPUs=$(nproc) State=UNKNOWN
PartitionName=farmtest Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -D -i -f "$SLURM_CONF" >"$T/slurmctld.stdout" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" >"$T/slurmd.stdout" 2>&1 &
pids+=($!)
for _ in $(seq 100); do
  [[ $(sinfo -h -N -o %T 2>/dev/null) == idle ]] && break
  sleep 0.2
done
[[ $(sinfo -h -N -o %T 2>/dev/null) == idle ]] || fail "the node did not come up idle ($(sinfo -h -N -o %T 2>&1))"
echo "farm-test: one-node Slurm up on $host in $((SECONDS - start)) s"

# The shot: jelly_drop (a drop onto the ground, contacts highlighted), 12 frames, small.
scene=$T/farm_drop.json
sed -e 's/"end": *36/"end": 12/' -e 's/"width": *480/"width": 160/' -e 's/"height": *270/"height": 90/' \
  -e 's/"name": *"jelly_drop"/"name": "farm_drop"/' scenes/jelly_drop.json >"$scene"
grep -q '"end": 12' "$scene" && grep -q '"width": 160' "$scene" || fail "could not shorten scenes/jelly_drop.json"
export LP_NUM_THREADS=1

"$DGV" -q render "$scene" --out "$T/ref" --threads 1
nref=$(ls "$T/ref"/*.png | wc -l)
[[ $nref -eq 12 ]] || fail "the plain render wrote $nref frames, not 12"
echo "farm-test: plain render done at $((SECONDS - start)) s"

# A still scene needs no simulation job.
"$DGV" farm submit scenes/primitives.json --chunk 4 --out "$T/still" --dry-run | grep -q "no simulation job" \
  || fail "the scene without dynamics got a simulation job"

"$DGV" farm submit "$scene" --chunk 4 --out "$T/shot" | tee "$T/submit.txt"
array=$(awk '/^render/ {print $2}' "$T/submit.txt")
[[ -n $array ]] || fail "no render job id printed"

# Cancel task 1 while it renders (after the simulation has finished).
for _ in $(seq 600); do
  state=$(squeue -h -j "${array}_1" -o %T 2>/dev/null || true)
  [[ $state == RUNNING ]] && break
  [[ -z $state && -f $T/shot/farm/done/render.1 ]] && break
  sleep 0.1
done
[[ $state == RUNNING ]] || fail "render task 1 never ran (state '$state')"
# Mid-run: once its first frame is on disk, well before its fourth.
for _ in $(seq 400); do grep -q "render 1/4" "$T/shot/farm/logs/render.1.out" 2>/dev/null && break; sleep 0.05; done
scancel "${array}_1"
echo "farm-test: cancelled render task ${array}_1 at $((SECONDS - start)) s"

# Until no job runs or can still start (a job whose dependency failed waits for ever; resubmit
# cancels it).
wait_queue() {
  for _ in $(seq 600); do
    [[ -z $(squeue -h -o '%i %r' 2>/dev/null | grep -v DependencyNeverSatisfied) ]] && return 0
    sleep 0.2
  done
  fail "the queue did not empty: $(squeue)"
}
wait_queue
"$DGV" farm status "$T/shot" | tee "$T/status1.txt"
ls -a "$T/shot" | grep -q '\.tmp-' && fail "a partial frame was left: $(ls -a "$T/shot" | grep '\.tmp-')"
grep -q "render task 1 (frames 5-8): done" "$T/status1.txt" && fail "task 1 finished before it was cancelled; nothing was resumed"

# The frames of the tasks that completed must not be written again.
stat -c '%n %i %Y' "$T"/shot/farm_drop.000[1-4].png "$T"/shot/farm_drop.00{09,10,11,12}.png >"$T/kept.before"
"$DGV" farm resubmit "$T/shot" | tee "$T/resubmit.txt"
grep -q "(tasks 1)" "$T/resubmit.txt" || fail "resubmit did not submit exactly the cancelled task"
wait_queue
"$DGV" farm status "$T/shot" --check | tee "$T/status2.txt"
[[ $(cat "$T/shot/farm/done/check") == 0 ]] || fail "the check job did not pass"
stat -c '%n %i %Y' "$T"/shot/farm_drop.000[1-4].png "$T"/shot/farm_drop.00{09,10,11,12}.png >"$T/kept.after"
cmp -s "$T/kept.before" "$T/kept.after" || fail "frames of completed tasks were written again"

n=0
for f in "$T"/ref/farm_drop.*.png; do
  cmp "$f" "$T/shot/$(basename "$f")" || fail "$(basename "$f") differs from the plain render"
  n=$((n + 1))
done
[[ $n -eq 12 ]] || fail "compared $n frames, not 12"
ls -a "$T/shot" | grep -q '\.tmp-' && fail "a temporary file was left in the shot folder"
echo "farm-test: OK: 12 frames byte-identical to the plain render, task 1 resumed, in $((SECONDS - start)) s"
