#!/usr/bin/env bash
# A rank killed from outside (SIGKILL mid-run, as a lost node or the OOM
# killer would): mpirun ends every other rank and exits non-zero, naming
# the rank and the signal; nothing hangs and no rank is left running.
# Run by ctest (label mpi): mpi_kill_test.sh SODA MPIEXEC
set -u
soda=$1
mpiexec=$2
out=$(mktemp)
trap 'rm -f "$out"' EXIT

# Long enough never to end by itself while the test runs (a million steps).
"$mpiexec" --oversubscribe -np 2 "$soda" run --scene falling-cubes --n 2000 --steps 1000000 \
  --territories 2 --log-level warn >"$out" 2>&1 &
launcher=$!

# The rank processes: the launcher's children whose environment names their
# rank (Open MPI's OMPI_COMM_WORLD_RANK); never another test's ranks.
rank_pid() {
  local pid
  for pid in $(pgrep -P "$launcher"); do
    if tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -qx "OMPI_COMM_WORLD_RANK=$1"; then
      echo "$pid"
      return 0
    fi
  done
  return 1
}

# Wait (hang guard: 120 s) until both ranks run and have stepped a while:
# rank 0 prints nothing before the end, so wait for both processes and
# then give the worlds 2 s of stepping.
for _ in $(seq 1 1200); do
  r0=$(rank_pid 0) && r1=$(rank_pid 1) && break
  sleep 0.1
done
if [ -z "${r0:-}" ] || [ -z "${r1:-}" ]; then
  echo "FAIL: the two ranks never started" >&2
  cat "$out" >&2
  kill -9 "$launcher" 2>/dev/null
  exit 1
fi
sleep 2
if ! kill -0 "$r0" 2>/dev/null || ! kill -0 "$r1" 2>/dev/null; then
  echo "FAIL: a rank ended before it was killed" >&2
  cat "$out" >&2
  exit 1
fi
kill -9 "$r1"

# mpirun must end the job by itself (hang guard: 120 s, far above the
# second or two it takes).
for _ in $(seq 1 1200); do
  kill -0 "$launcher" 2>/dev/null || break
  sleep 0.1
done
if kill -0 "$launcher" 2>/dev/null; then
  echo "FAIL: mpirun still runs 120 s after rank 1 was killed" >&2
  kill -9 "$launcher" "$r0" 2>/dev/null
  exit 1
fi
wait "$launcher"
rc=$?
echo "mpirun exited $rc after rank 1 (pid $r1) was killed; its output:"
cat "$out"
status=0
if [ "$rc" -eq 0 ]; then
  echo "FAIL: mpirun exited 0" >&2
  status=1
fi
if ! grep -q "rank 1" "$out" || ! grep -qi "signal 9\|killed" "$out"; then
  echo "FAIL: mpirun's output does not name rank 1 and the signal" >&2
  status=1
fi
# Rank 0 ends with the job: gone or a zombie waiting to be reaped (hang
# guard: 30 s; it takes well under a second).
alive() { local st; st=$(ps -o stat= -p "$1" 2>/dev/null) && [ -n "$st" ] && [ "${st#Z}" = "$st" ]; }
for _ in $(seq 1 300); do
  alive "$r0" || break
  sleep 0.1
done
if alive "$r0"; then
  echo "FAIL: rank 0 (pid $r0) still runs 30 s after the job ended" >&2
  kill -9 "$r0"
  status=1
fi
exit $status
