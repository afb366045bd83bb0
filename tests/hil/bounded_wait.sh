# bounded_wait.sh - sourced by the test scripts: waits that cannot hang.
#
# bounded_wait PID SECONDS WHERE
#   Waits up to SECONDS for the background child PID and returns its exit status. If it is
#   still running then, prints "FAIL: hung: WHERE (pid PID still running after SECONDS s)",
#   sends SIGTERM, then SIGKILL 2 s later, and returns 124.
bounded_wait() {
  local pid=$1 secs=$2 where=$3 n=0 limit
  limit=$((secs * 10))
  while _bw_alive "$pid"; do
    if [ "$n" -ge "$limit" ]; then
      echo "FAIL: hung: $where (pid $pid still running after $secs s)"
      kill -TERM "$pid" 2>/dev/null
      n=0
      while _bw_alive "$pid" && [ "$n" -lt 20 ]; do sleep 0.1; n=$((n + 1)); done
      kill -KILL "$pid" 2>/dev/null
      wait "$pid" 2>/dev/null
      return 124
    fi
    sleep 0.1
    n=$((n + 1))
  done
  wait "$pid"
}

# A zombie (exited, not yet reaped) counts as gone.
_bw_alive() {
  kill -0 "$1" 2>/dev/null || return 1
  local st
  st=$(awk '{ print $3 }' "/proc/$1/stat" 2>/dev/null) || return 1
  [ -n "$st" ] && [ "$st" != Z ]
}

# bounded_run SECONDS WHERE -- command...: a foreground command with a time limit; on
# expiry prints the FAIL line and returns 124 (SIGTERM, then SIGKILL 2 s later).
bounded_run() {
  local secs=$1 where=$2 rc
  shift 3
  timeout -k 2 "$secs" "$@"
  rc=$?
  [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ] && { echo "FAIL: hung: $where (still running after $secs s)"; return 124; }
  return "$rc"
}

# test_lcm_url: prints a udpm URL of the test's own: ttl=0, a random port of the tests' range
# 7900-10999 (never LCM's and omni4's default 7667, nor bench/'s 7700-7899), so a robot running
# on the default URL on this machine never meets a test, nor a test another one.
test_lcm_url() {
  echo "udpm://239.255.76.67:$((7900 + RANDOM % 3100))?ttl=0"
}
