# One whole process timed with /usr/bin/time (GNU time, Debian package time): sourced by
# scripts/peer_bench.sh and scripts/scale_bench.sh, so both time the same way.
#   timed_run DIR STDOUT STDERR CMD...   runs CMD in DIR (created empty first), its output to
#                                        the files STDOUT and STDERR; sets TIMED_WALL,
#                                        TIMED_USER, TIMED_SYS (seconds), TIMED_RSS (peak
#                                        resident set, KiB) and TIMED_RC (its exit status)
timed_run() {
  local dir=$1 out=$2 err=$3; shift 3
  local tf; tf=$(mktemp)
  rm -rf "$dir"; mkdir -p "$dir"
  TIMED_RC=0
  (cd "$dir" && /usr/bin/time -f '%e %U %S %M' -o "$tf" "$@" >"$out" 2>"$err") || TIMED_RC=$?
  read -r TIMED_WALL TIMED_USER TIMED_SYS TIMED_RSS < <(tail -1 "$tf")
  rm -f "$tf"
}

# Run directly (not sourced): the usage and the header above, nothing run.
if [ "${BASH_SOURCE[0]}" = "$0" ]; then
  echo "usage: bash scripts/timed_run.sh --help (a library: 'source scripts/timed_run.sh', then timed_run DIR STDOUT STDERR CMD...)"
  sed -n '1,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"
  exit 0
fi
