# Sourced by the tests/cli_*.sh tests: a scratch folder, counted checks, and the closing line
# 'N passed, M failed' (ctest reads it; the exit status says the same).
set -u
: "${ENVLIGHT:?} ${ENVL_TEST_TMP:?}"
mkdir -p "$ENVL_TEST_TMP" && cd "$ENVL_TEST_TMP" || exit 1
fails=0
checks=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; }
# run COMMAND...: must exit 0; stdout in out.txt, stderr in err.txt
run() { checks=$((checks + 1)); "$@" >out.txt 2>err.txt || { fail "exit $?: $*"; cat err.txt; }; }
# usage COMMAND...: must exit 2 (bad usage)
usage() { checks=$((checks + 1)); "$@" >out.txt 2>err.txt; local rc=$?
  [ $rc = 2 ] || fail "exit $rc, expected 2: $*"; }
# expect STATUS DESCRIPTION -- COMMAND...
expect() { local want=$1 what=$2; shift 3; checks=$((checks + 1))
  "$@" >out.txt 2>err.txt; local got=$?
  [ "$got" = "$want" ] || { fail "$what: exit $got, expected $want: $*"; cat err.txt; }; }
# has FILE REGEX / hasnt FILE REGEX (grep basic regular expressions)
has() { checks=$((checks + 1)); grep -q -- "$2" "$1" || { fail "$1 lacks '$2'"; cat "$1"; }; }
hasnt() { checks=$((checks + 1)); ! grep -q -- "$2" "$1" || fail "$1 has '$2'"; }
# empty FILE
empty() { checks=$((checks + 1)); [ ! -s "$1" ] || { fail "$1 not empty"; cat "$1"; }; }
finish() { echo "$((checks - fails)) passed, $fails failed"; [ "$fails" = 0 ]; }
