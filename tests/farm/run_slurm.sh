#!/usr/bin/env bash
# A real farm: examples/farm/slurm_bake.sbatch, unchanged, run as a Slurm job array on a
# single-node Slurm that this script starts and stops itself (Debian 12's slurm-wlm and munge;
# .ci/bootstrap test installs them). ctest runs it as farm.slurm, label farm.
#
#   tests/farm/run_slurm.sh SOURCE_DIR BUILD_DIR SPECTEX_BINARY
#
# Everything lives in a fresh folder /tmp/spectex-farm-XXXXXX (short: Unix socket paths are limited
# to 108 bytes): munged with its own key and socket, slurmctld and slurmd with a generated
# slurm.conf (no cgroups, no accounting, two TCP ports free at the start of this run), the
# textures, the outputs and the job logs. The system's munge key and socket and /etc/slurm are not
# used (Slurm looks for its other files beside slurm.conf), so a daemon left over by an aborted run
# (other ports, socket and folder) can neither answer this run's clients nor block it.
#
# The checks, each an "ok:" or "FAILED:" line:
#   1. sbatch --array=1-3 of the example on a list of 6 PNGs: every task COMPLETED with exit 0,
#      every input baked exactly once, by the task whose shard it is, to OUTDIR/<stem>.exr and
#      nothing else there; each output passes `spectex info` and `spectex verify`; one JSON Lines
#      report and one log per task; no line in the logs but spectex's summary lines;
#   2. the same array again: the example passes --update, so every record is "skipped" and no
#      output is rewritten;
#   3. the list plus a broken PNG: the task whose shard holds it FAILED (non-zero exit code in
#      scontrol), the others COMPLETED, and the report and log say which file and why.
# When a daemon cannot run (not root, a refused port, the kernel), the script says so in a banner,
# with the daemon's log, and exits non-zero: it never skips. On failure the daemons' and the jobs'
# logs are copied to BUILD_DIR/farm-slurm-logs. On any exit it cancels its jobs, stops the daemons
# it started by their process ids, waits for (or kills) their job steps, and removes its folder.
set -uo pipefail
export LC_ALL=C
usage="usage: run_slurm.sh SOURCE_DIR BUILD_DIR SPECTEX_BINARY"
src=$(cd "${1:?$usage}" && pwd) || exit 2
build=$(cd "${2:?$usage}" && pwd) || exit 2
spectex=${3:?$usage}
[ -x "$spectex" ] || { echo "run_slurm.sh: $spectex is not an executable" >&2; exit 2; }
spectex=$(cd "$(dirname "$spectex")" && pwd)/$(basename "$spectex")
sbatch_script=$src/examples/farm/slurm_bake.sbatch
python=/usr/bin/python3; [ -x "$python" ] || python=python3
logs_keep=$build/farm-slurm-logs
start=$(date +%s)

banner() { echo "########################################################################" >&2; }
loud() {  # loud LINE...: a banner nobody scrolls past
  banner; local l; for l in "$@"; do echo "farm.slurm: $l" >&2; done; banner
}
fail=0
check() {  # check "what" command...: one ok/FAILED line, the command's output only on failure
  local what=$1 out; shift
  if out=$("$@" 2>&1); then echo "ok: $what"; else echo "FAILED: $what"; fail=1; [ -z "$out" ] || echo "$out" | sed 's/^/  /'; fi
}

# --- Preconditions: said loudly, never a skip. ---------------------------------------------------
if [ "$(id -u)" != 0 ]; then
  loud "FAILED: this test must run as root (uid is $(id -u)), so the Slurm example is NOT tested." \
       "slurmd starts each job as the user who submitted it (setuid), and the test starts munged," \
       "slurmctld and slurmd itself; .ci/bootstrap test runs as root. Run it as root, or leave" \
       "the label out (ctest -LE farm) knowing that examples/farm/slurm_bake.sbatch is then untested."
  exit 1
fi
missing=()
for c in munged mungekey munge unmunge slurmctld slurmd sbatch scontrol sinfo squeue scancel oiiotool; do
  command -v "$c" >/dev/null || missing+=("$c")
done
if [ ${#missing[@]} -gt 0 ]; then
  loud "FAILED: missing commands: ${missing[*]}, so the Slurm example is NOT tested." \
       "apt-get install slurm-wlm munge openimageio-tools (.ci/bootstrap test installs them)."
  exit 1
fi

# --- The run's folder, and the clean-up that always runs. ----------------------------------------
tmp=$(mktemp -d /tmp/spectex-farm-XXXXXX) || exit 1
chmod 755 "$tmp"  # munged wants every folder above its socket searchable by all
mkdir -m 700 "$tmp/munge" && mkdir -m 755 "$tmp/run" "$tmp/slurm" "$tmp/state" "$tmp/spool" \
  "$tmp/work" "$tmp/in" "$tmp/out" || exit 1
cd "$tmp" || exit 1  # the daemons' working folder, and so their job steps': see leftovers()
export SLURM_CONF=$tmp/slurm/slurm.conf SPECTEX=$spectex
unset SLURM_JOB_ID SLURM_JOBID SLURM_ARRAY_JOB_ID SLURM_ARRAY_TASK_ID  # when run inside a job
pids=() names=() errs=() logs=()  # the daemons this run started, in start order
jobids=()                          # the jobs it submitted
client() { timeout 20 "$@"; }      # a client never hangs the test, even with the daemons gone

stop_pid() {  # stop_pid PID NAME: TERM, up to 15 s, then KILL
  local pid=$1 name=$2 i
  kill -0 "$pid" 2>/dev/null || return 0
  kill -TERM "$pid" 2>/dev/null
  for i in $(seq 150); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.1; done
  echo "farm.slurm: $name (pid $pid) still running 15 s after TERM: KILL" >&2
  kill -KILL "$pid" 2>/dev/null
}
leftovers() {  # live processes but this shell whose working folder or an open file is in $tmp
  find /proc/[0-9]*/cwd /proc/[0-9]*/fd -maxdepth 1 \( -lname "$tmp" -o -lname "$tmp/*" \) 2>/dev/null \
    | cut -d/ -f3 | sort -u | grep -vx "$$"
}
cleanup() {
  local rc=$? i pid left
  trap - EXIT INT TERM HUP
  trap '' PIPE  # a reader gone (| head): the clean-up still runs to its end
  cd /
  if [ ${#jobids[@]} -gt 0 ] && [ ${#pids[@]} -gt 1 ] && kill -0 "${pids[1]}" 2>/dev/null; then
    client scancel "${jobids[@]}" 2>/dev/null  # finished ones are left as they are
  fi
  if [ $rc != 0 ] || [ $fail != 0 ]; then
    rm -rf "$logs_keep" && mkdir -p "$logs_keep" \
      && cp -r "$tmp/slurm" "$tmp/work" "$tmp/munge/munged.log" "$logs_keep/" 2>/dev/null
    echo "farm.slurm: the daemons' and the jobs' logs are in $logs_keep" >&2
  else
    rm -rf "$logs_keep"  # an earlier failure's
  fi
  # Reverse start order: slurmd, slurmctld, munged.
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do stop_pid "${pids[$i]}" "${names[$i]}"; done
  # Job steps (slurmstepd and the job) outlive slurmd by design. Each of ours works in $tmp or
  # holds a log there: give them 10 s to end, then kill them by process id.
  for i in $(seq 100); do left=$(leftovers); [ -z "$left" ] && break; sleep 0.1; done
  if [ -n "$left" ]; then
    echo "farm.slurm: still using $tmp 10 s after the daemons stopped, killed:" >&2
    for pid in $left; do
      echo "  $pid $(tr "\0" " " <"/proc/$pid/cmdline" 2>/dev/null)" >&2; kill -KILL "$pid" 2>/dev/null
    done
  fi
  rm -rf "$tmp"
  [ $rc = 0 ] && rc=$fail
  echo "farm.slurm: $([ $rc = 0 ] && echo passed || echo FAILED) in $(( $(date +%s) - start )) s"
  exit $rc
}
trap cleanup EXIT
on_signal() {  # on_signal NAME STATUS: say so (a reader gone, SIGPIPE, is not re-raised), exit
  trap '' PIPE; echo "farm.slurm: interrupted (SIG$1)" >&2; exit "$2"
}
trap 'on_signal INT 130' INT; trap 'on_signal TERM 143' TERM; trap 'on_signal HUP 129' HUP
trap 'on_signal PIPE 141' PIPE

daemon_failed() {  # daemon_failed INDEX|NAME WHAT: a banner with the daemon's output, then exit 1
  local name=$1 err=/dev/null log=/dev/null f i
  for i in "${!names[@]}"; do
    [ "${names[$i]}" = "$name" ] && { err=${errs[$i]}; log=${logs[$i]}; }
  done
  banner
  echo "farm.slurm: FAILED: $name $2." >&2
  echo "farm.slurm: this machine did not run a single-node Slurm, so the Slurm example is NOT tested." >&2
  for f in "$err" "$log"; do
    [ -s "$f" ] || continue
    echo "farm.slurm: the last lines of $f:" >&2
    tail -n 25 "$f" | sed 's/^/    /' >&2
  done
  banner
  exit 1
}
start_daemon() {  # start_daemon NAME LOG COMMAND...: in the foreground, as a background job
  local name=$1 log=$2; shift 2
  "$@" >"$tmp/slurm/$name.stderr" 2>&1 &
  pids+=($!); names+=("$name"); errs+=("$tmp/slurm/$name.stderr"); logs+=("$log")
}
daemons_alive() {  # or a banner naming the first one that died
  local i
  for i in "${!pids[@]}"; do
    kill -0 "${pids[$i]}" 2>/dev/null || daemon_failed "${names[$i]}" "exited (pid ${pids[$i]}) ${1:-}"
  done
}
wait_for() {  # wait_for SECONDS NAME WHAT COMMAND...: until COMMAND succeeds, with the daemons up
  local secs=$1 name=$2 what=$3 t; shift 3
  for ((t = 0; t < secs * 10; t++)); do
    "$@" >/dev/null 2>&1 && return 0
    daemons_alive "before $what"
    sleep 0.1
  done
  daemon_failed "$name" "gave no $what in $secs s"
}

# --- munged: its own key, socket, pid file, log and seed. -----------------------------------------
sock=$tmp/run/munge.socket
mungekey --create --keyfile="$tmp/munge/munge.key" >"$tmp/slurm/mungekey.stderr" 2>&1 \
  || { cat "$tmp/slurm/mungekey.stderr" >&2; daemon_failed mungekey "could not create a key"; }
start_daemon munged "$tmp/munge/munged.log" munged --foreground --force \
  --key-file="$tmp/munge/munge.key" --socket="$sock" --pid-file="$tmp/run/munged.pid" \
  --log-file="$tmp/munge/munged.log" --seed-file="$tmp/munge/munged.seed"
munge_ok() { munge -n -S "$sock" | unmunge -S "$sock"; }
wait_for 20 munged "credential through $sock" munge_ok

# --- slurm.conf: one node on 127.0.0.1, two free ports, every path in $tmp. ----------------------
read -r ctld_port slurmd_port < <("$python" -c '
import socket
ss = [socket.socket() for _ in range(2)]
for s in ss: s.bind(("127.0.0.1", 0))
print(*(s.getsockname()[1] for s in ss))')
[ -n "${slurmd_port:-}" ] || daemon_failed slurmctld "has no port: python3 could not pick two free TCP ports"
host=$(hostname -s)
node=spectexfarm
# The example asks for --cpus-per-task=2 --mem=2G. The node is declared with at least 6 CPUs and
# 2 GB (SlurmdParameters=config_overrides: slurmd takes the declared size, whatever the hardware),
# so the script runs unchanged on any machine and its three tasks run at the same time, as on a
# farm, writing into one folder. Their textures are tiny.
cpus=$(nproc); [ "$cpus" -ge 6 ] || cpus=6
mem=$(awk '/^MemTotal:/ { print int($2 / 1024) }' /proc/meminfo); [ "$mem" -ge 2048 ] || mem=2048
cat >"$SLURM_CONF" <<CONF
# Generated by tests/farm/run_slurm.sh for one run, and removed with it.
ClusterName=spectexfarm
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$sock
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/run/slurmctld.pid
SlurmdPidFile=$tmp/run/slurmd.pid
SlurmctldLogFile=$tmp/slurm/slurmctld.log
SlurmdLogFile=$tmp/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
SlurmdParameters=config_overrides
MinJobAge=600
KillWait=5
InactiveLimit=0
NodeName=$node NodeHostname=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=farm Nodes=$node Default=YES MaxTime=INFINITE State=UP
CONF
start_daemon slurmctld "$tmp/slurm/slurmctld.log" slurmctld -D -i -f "$SLURM_CONF"
ctld_up() { client scontrol ping | grep -q 'is UP'; }
wait_for 30 slurmctld "answer to scontrol ping on port $ctld_port" ctld_up
start_daemon slurmd "$tmp/slurm/slurmd.log" slurmd -D -f "$SLURM_CONF" -N "$node"
node_idle() { [ "$(client sinfo -h -n "$node" -o %t)" = idle ]; }
wait_for 60 slurmd "idle node $node in sinfo (slurmd on port $slurmd_port)" node_idle
echo "ok: munged, slurmctld (port $ctld_port) and slurmd (port $slurmd_port) up, node $node idle" \
     "($cpus CPUs, $mem MB) in $(( $(date +%s) - start )) s"

# --- Six small PNGs in an asset tree, two of one name in different folders, listed out of order ---
# (the shards follow the byte-sorted list: a, b, c, chair/diffuse, d, table/diffuse; the two
# diffuse.png fall into shards 1 and 3, so an example that did not mirror the tree would give them
# one output: every task refused, exit 2).
stems=(a b c chair/diffuse d table/diffuse)
mkdir -p "$tmp/in/chair" "$tmp/in/table"
for i in "${!stems[@]}"; do
  oiiotool --pattern "constant:color=0.$((i + 1)),0.$((8 - i)),0.5" 48x32 3 -d uint8 \
    -o "$tmp/in/${stems[$i]}.png" || { loud "FAILED: oiiotool could not write a texture"; exit 1; }
done
printf '%s\n' "$tmp"/in/{table/diffuse,c,a,d,chair/diffuse,b}.png >"$tmp/list.txt"

# --- Submitting the example and waiting for it. ---------------------------------------------------
submit() {  # submit LIST OUTDIR: the example as a 3-task array over the tree $tmp/in, from $tmp/work; sets $job
  job=$(cd "$tmp/work" && client sbatch --parsable --array=1-3 "$sbatch_script" "$1" "$2" "$tmp/in")
  [[ "$job" =~ ^[0-9]+$ ]] || { daemons_alive; loud "FAILED: sbatch refused the example: $job"; exit 1; }
  jobids+=("$job")
}
task_states() {  # task_states JOB: "TASK STATE EXITCODE" per line, one line a task (or a pending range)
  client scontrol show job -o "$1" | awk '{
    t = s = e = ""
    for (i = 1; i <= NF; i++) {
      n = index($i, "="); k = substr($i, 1, n - 1); v = substr($i, n + 1)
      if (k == "ArrayTaskId") t = v; else if (k == "JobState") s = v; else if (k == "ExitCode") e = v
    }
    print t, s, e }' | sort
}
wait_array() {  # wait_array JOB SECONDS: until its 3 tasks are each in a final state
  local t states
  for ((t = 0; t < $2 * 5; t++)); do
    states=$(task_states "$1" 2>/dev/null)
    if [ "$(wc -l <<<"$states")" = 3 ] \
       && ! grep -qvE '^[0-9]+ (COMPLETED|FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY|BOOT_FAIL|DEADLINE|PREEMPTED) ' <<<"$states"; then
      return 0
    fi
    daemons_alive "while job $1 ran"
    sleep 0.2
  done
  loud "FAILED: job $1 not finished in $2 s; its tasks:" "$states" "$(client squeue 2>&1)"
  exit 1
}
task_log() { echo "$tmp/work/spectex-$1_$2.log"; }  # the example's --output=spectex-%A_%a.log
log_says() {  # log_says JOB TASK REGEX [ANY]: a line of the task's log matches REGEX, and unless
  # ANY, every line is spectex's count line or a colour-space line: no failed file ("spectex: FILE:
  # reason"), no warning, no "slurmstepd: error: ..."
  local log other; log=$(task_log "$1" "$2")
  [ -f "$log" ] || { echo "no log $log"; return 1; }
  grep -qE "$3" "$log" || { echo "no line of $log matches '$3':"; cat "$log"; return 1; }
  [ "${4:-}" = ANY ] && return 0
  other=$(grep -vE "^spectex: ([0-9]+ baked, [0-9]+ up to date, [0-9]+ failed of [0-9]+ in |colour space ')" "$log")
  [ -z "$other" ] || { echo "unexpected lines in $log:"; echo "$other"; return 1; }
}
reports() {  # reports JOB LIST EXPECT [FAILING]: tests/farm/check_reports.py
  "$python" "$src/tests/farm/check_reports.py" "$tmp/out" "$tmp/in" "$1" 3 "$2" "${@:3}"
}
all_completed="$(printf '%s COMPLETED 0:0\n' 1 2 3)"

# --- 1. The array bakes every input once. --------------------------------------------------------
submit "$tmp/list.txt" "$tmp/out"
wait_array "$job" 180
check "job $job: tasks 1-3 COMPLETED, exit code 0:0" test "$(task_states "$job")" = "$all_completed"
check "each input in one task's JSON Lines report, status ok, in the report of its shard's task" \
  reports "$job" "$tmp/list.txt" ok
outputs() { (cd "$tmp/out" && find . -mindepth 1 ! -name '*.jsonl' | sort | tr '\n' ' '); }
tree="./a.exr ./b.exr ./c.exr ./chair ./chair/diffuse.exr ./d.exr ./table ./table/diffuse.exr "
check "the output folder mirrors the tree: the six EXRs, their two folders and the three reports, nothing else" \
  test "$(outputs) $(ls -A "$tmp/out" | grep '\.jsonl$' | tr '\n' ' ')" = "$tree spectex-$job-1.jsonl spectex-$job-2.jsonl spectex-$job-3.jsonl "
info_ok() {  # info_ok STEM: spectex info reads OUTDIR/STEM.exr as a spectral file baked from IN/STEM.png
  local info; info=$("$spectex" info "$tmp/out/$1.exr") || return 1
  grep -qxE ' *layout: +spectralLayoutVersion 1\.0, reflective' <<<"$info" \
    && grep -qxE ' *size: +48 x 32' <<<"$info" && grep -qxE ' *bins: +31' <<<"$info" \
    && grep -qxF "  spectex:source $tmp/in/$1.png" <<<"$info" || { echo "$info"; return 1; }
}
for s in "${stems[@]}"; do
  check "spectex info $s.exr: spectral layout 1.0, 48 x 32, 31 bins (the default's 400:700:10), source $s.png" info_ok "$s"
done
baked=(); for s in "${stems[@]}"; do baked+=("$tmp/out/$s.exr"); done
check "spectex verify --source-from-header on the six" "$spectex" verify "${baked[@]}" --source-from-header
for k in 1 2 3; do
  check "task $k's log: 2 baked, nothing else" log_says "$job" $k '^spectex: 2 baked, 0 up to date, 0 failed of 2 in '
done

# --- 2. The same array again: --update skips everything, rewrites nothing. -----------------------
snapshot() { find "$tmp/out" -name '*.exr' -printf '%P %i %s %T@\n' | sort; }
before=$(snapshot)
submit "$tmp/list.txt" "$tmp/out"
wait_array "$job" 180
check "job $job (the same again): tasks 1-3 COMPLETED, exit code 0:0" test "$(task_states "$job")" = "$all_completed"
check "each input reported once, status skipped, by its shard's task" reports "$job" "$tmp/list.txt" skipped
check "no output rewritten (names, inodes, sizes, modification times)" test "$(snapshot)" = "$before"
for k in 1 2 3; do
  check "task $k's log: 2 up to date, nothing else" log_says "$job" $k '^spectex: 0 baked, 2 up to date, 0 failed of 2 in '
done

# --- 3. A broken input fails its task, and the array's state says so. ----------------------------
printf 'not a PNG\n' >"$tmp/in/u_broken.png"
{ cat "$tmp/list.txt"; echo "$tmp/in/u_broken.png"; } >"$tmp/list-broken.txt"
# Byte-sorted, u_broken.png is file 6 (from 0): shard 6 mod 3 + 1 = 1, with a.png and chair/diffuse.png.
submit "$tmp/list-broken.txt" "$tmp/out"
wait_array "$job" 180
states=$(task_states "$job")
check "job $job (a broken input in shard 1): task 1 FAILED with a non-zero exit code" \
  grep -qE '^1 FAILED [1-9][0-9]*:0$' <<<"$states"
check "tasks 2 and 3 COMPLETED, exit code 0:0" test "$(grep -v '^1 ' <<<"$states")" = "$(printf '%s COMPLETED 0:0\n' 2 3)"
check "the broken input reported once, failed with an error, the others skipped, each by its shard's task" \
  reports "$job" "$tmp/list-broken.txt" skipped "$tmp/in/u_broken.png"
check "task 1's log counts the failure" log_says "$job" 1 '^spectex: 0 baked, 2 up to date, 1 failed of 3 in ' ANY
check "task 1's log names the broken file and why" log_says "$job" 1 "^spectex: $tmp/in/u_broken\\.png: ." ANY
for k in 2 3; do
  check "task $k's log: 2 up to date, nothing else" log_says "$job" $k '^spectex: 0 baked, 2 up to date, 0 failed of 2 in '
done
check "no output for the broken input, no temporary file left" \
  test "$(outputs)" = "$tree"
echo "job $job's tasks (task, state, exit code):"; sed 's/^/  /' <<<"$states"
[ $fail = 0 ] || loud "FAILED: the Slurm job array did not do what examples/farm/README.md says (above)"
