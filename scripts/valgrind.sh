#!/usr/bin/env bash
# The test suite under Valgrind's memcheck: every C test executable, and the command-line tests
# with `envlight` itself run under memcheck. Any invalid read or write, use of an uninitialised
# value, bad free, or definite / indirect leak fails the run.
#   bash scripts/valgrind.sh [BUILD_DIR] [--all | --quick] [-j N] [--docs DIR]
# BUILD_DIR (default build) is built first (scripts/build.sh). Without --all the tests that take
# more than ~10 s natively are left out (memcheck runs code 20-50x slower): test_layout,
# test_lights, test_prefilter and test_preview (their large maps; the same code runs on small
# maps in the others and in the CLI tests), test_pov_include (7 s, but its write-fault loop
# writes the include once per write step: 339 s under memcheck; CI runs it under ASan and
# UBSan), test_error_paths (every failing call, each scenario three times: LeakSanitizer checks
# it in CI's ASan run), test_furnace (prefilter chains on 20 maps up to 1024 x 512) and
# test_level_width (8 s natively: levels rendered at the widths it states; over 15 min under
# memcheck on a loaded machine; CI runs it under ASan and UBSan). The C tests run with ENVL_UNDER_MEMCHECK=1: test_irradiance then leaves out its
# brute-force comparison on the 12 maps (the sky and the synthetic maps stay; natively and
# under ASan it runs them all). The POV-Ray, main-job and Python/Blender tests are always left
# out: they spend their time in external programs, not in envlight. Memcheck runs all threads
# of a program on one core, so N tests run at once (default: the number of cores). --quick (what
# CI runs) keeps, of the CLI tests, cli_basics and cli_malformed: the bad-input paths.
# --docs DIR: also write DIR/valgrind.md (the command, date, load average, machine, each
# test's result and seconds, the totals of wall and CPU time; DIR, like BUILD_DIR, relative to
# the repository's top); how to read it: docs/reliability.md.
usage="usage: bash scripts/valgrind.sh [BUILD_DIR] [--all | --quick] [-j N] [--docs DIR]"
case "${1:-}" in  # --help: the usage and the header above, nothing run
  -h|--help) echo "$usage"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
esac
set -uo pipefail
command_line="bash scripts/valgrind.sh $*"
docs=
cd "$(dirname "$0")/.."
root=$PWD
build=build
all=0
quick=0
jobs=$(nproc)
while (($#)); do
  case $1 in
    --all) all=1 ;;
    --quick) quick=1 ;;
    -j) jobs=${2:?-j needs a number}; shift ;;
    --docs) docs=${2:?--docs needs a folder}; shift ;;
    -*) echo "$usage" >&2; exit 2 ;;
    *) build=$1 ;;
  esac
  shift
done
if [ -n "$docs" ]; then mkdir -p "$docs" && docs=$(cd "$docs" && pwd) || exit 1; fi
command -v valgrind >/dev/null || { echo "envlight: valgrind is not installed (Debian: valgrind)" >&2; exit 1; }
bash scripts/build.sh "$build" >/dev/null || exit 1
build=$(cd "$build" && pwd)
logs=$build/valgrind
# world-writable (sticky) because cli_malformed runs some commands as the user nobody
rm -rf "$logs" && mkdir -p "$logs" && chmod 1777 "$logs"

# --errors-for-leak-kinds: "still reachable" (e.g. a thread-local error message, libc's own
# buffers) is not a leak; "possible" is reported by glibc's thread stacks, so it is shown only.
vg=(valgrind --tool=memcheck --leak-check=full --errors-for-leak-kinds=definite,indirect
    --show-leak-kinds=definite,indirect --track-origins=yes --error-exitcode=99 --quiet)
shared=${ENVL_SHARED_DATA:-$root/../shared/data}
slow='^(test_layout|test_lights|test_prefilter|test_preview|test_pov_include|test_error_paths|test_furnace|test_level_width)$'
start=$(date +%s); date0=$(date +%Y-%m-%dT%H:%M:%S); load0=$(cut -d' ' -f1-3 /proc/loadavg)

# The CLI tests call $ENVLIGHT: a wrapper that runs the real binary under memcheck, one log per
# process (a test that expects exit 1 sees 99 if memcheck finds an error).
wrap=$logs/envlight
cat >"$wrap" <<EOF
#!/bin/sh
exec ${vg[*]} --log-file="$logs/envlight.%p.log" "$build/envlight" "\$@"
EOF
chmod 755 "$wrap"

# run_one NAME: one test; writes $logs/NAME.result ("ok ..." or "FAIL ...").
run_one() {
  local name=$1 t rc
  t=$(date +%s)
  if [[ $name == test_* ]]; then
    (cd "$build/tests" && ENVL_UNDER_MEMCHECK=1 "${vg[@]}" --log-file="$logs/$name.log" "./$name" \
        >"$logs/$name.out" 2>&1)
    rc=$?
    # exit 77 = the test skipped itself (data absent)
    if { [ $rc != 0 ] && [ $rc != 77 ]; } || [ -s "$logs/$name.log" ]; then
      echo "FAIL: $name (exit $rc; memcheck log $logs/$name.log, output $logs/$name.out)" >"$logs/$name.result"
      return
    fi
  else
    mkdir -p "$logs/tmp" && chmod 1777 "$logs/tmp"
    ENVLIGHT=$wrap ENVL_SHARED_DATA=$shared ENVL_TEST_TMP=$logs/tmp/$name \
      bash "tests/$name.sh" >"$logs/$name.out" 2>&1
    rc=$?
    if [ $rc != 0 ] && [ $rc != 77 ]; then
      echo "FAIL: $name (exit $rc; output $logs/$name.out)" >"$logs/$name.result"
      return
    fi
  fi
  echo "ok: $name ($(( $(date +%s) - t )) s)" >"$logs/$name.result"
}

names=()
skipped=
for exe in "$build"/tests/test_*; do
  [ -x "$exe" ] && [ -f "$exe" ] || continue
  name=$(basename "$exe")
  if [ $all = 0 ] && [[ $name =~ $slow ]]; then
    echo "SKIP: $name (slow under memcheck; --all runs it)"; skipped+="$name (slow under memcheck; --all runs it), "
  else
    names+=("$name")
  fi
done
for src in tests/cli_*.sh; do
  name=$(basename "$src" .sh)
  case $name in
    cli_pov | cli_main_job) echo "SKIP: $name (POV-Ray)"; skipped+="$name (POV-Ray), " ;;
    cli_basics | cli_malformed) names+=("$name") ;;
    *) if [ $quick = 1 ]; then echo "SKIP: $name (--quick)"; skipped+="$name (--quick), "; else names+=("$name"); fi ;;
  esac
done
# the longest first, so that the two cores finish together
order=$(for n in "${names[@]}"; do
  case $n in cli_* | test_sh) echo "0 $n" ;; *) echo "1 $n" ;; esac
done | sort | cut -d' ' -f2)
running=0
for name in $order; do
  if ((running >= jobs)); then
    wait -n
    running=$((running - 1))
  fi
  run_one "$name" &
  running=$((running + 1))
done
wait

fails=0
for name in $order; do
  cat "$logs/$name.result"
  if grep -q '^FAIL' "$logs/$name.result"; then
    fails=$((fails + 1))
    [ -s "$logs/$name.log" ] && cat "$logs/$name.log"
    tail -20 "$logs/$name.out"
  fi
done
for log in "$logs"/envlight.*.log; do
  [ -s "$log" ] || continue
  fails=$((fails + 1))
  echo "FAIL: memcheck found errors in an envlight run: $log"
  cat "$log"
done
wall=$(( $(date +%s) - start ))
echo "valgrind: ${#names[@]} tests, $fails failed, $wall s"
if [ -n "$docs" ]; then
  times >"$logs/times"   # line 2: the user and system time of the finished children
  read -r cpu_user cpu_sys < <(sed -n 2p "$logs/times")
  cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
  {
    echo "# The test suite under Valgrind's memcheck"
    echo
    echo "Written by \`$command_line\` (do not edit by hand; run it again to update this file)."
    echo
    echo "- date: $date0; wall $(( wall / 60 )) min $(( wall % 60 )) s; CPU (user, system) $cpu_user, $cpu_sys"
    echo "- load average at start / end: $load0 / $(cut -d' ' -f1-3 /proc/loadavg)"
    echo "- machine: ${cpu:-$(uname -m)}, $(nproc) cores; $(valgrind --version); $jobs at a time"
    echo "- result: ${#names[@]} tests, $fails failed (memcheck: invalid accesses, uninitialised"
    echo "  values, bad frees, definite and indirect leaks are errors)"
    echo
    echo "| test | result |"
    echo "|---|---|"
    for name in $order; do
      sed 's/^\(ok\|FAIL\): [^ ]* \{0,1\}/| '"$name"' | \1 /; s/$/ |/' "$logs/$name.result"
    done
    echo
    echo "Left out: ${skipped:-nothing}the Python, Blender and POV-Ray tests (external programs)."
  } >"$docs/.valgrind.md.tmp-$$" && mv -f "$docs/.valgrind.md.tmp-$$" "$docs/valgrind.md"
  echo "valgrind: wrote $docs/valgrind.md"
fi
[ $fails = 0 ]
