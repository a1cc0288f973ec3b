#!/usr/bin/env bash
# Temporaries a killed run left (issue 30, 4: SIGKILL leaves .envl-PID-* files that no later
# run removed). Every writer names its temporary .envl-PID-... in the target's folder; a later
# run writing into that folder removes those of processes that are gone: named .envl-PID-,
# a regular file of this user, and its PID no longer running or its last change more than a
# day old (a PID reused since). Kept: a running process's (this shell's, recent), another
# user's, a symbolic link, a name that only looks alike, and anything else in the folder.
. "$(dirname "$0")/clitest.sh"

rm -rf stale && mkdir stale && cd stale || exit 1
# a PID that is no longer running: a process killed as SIGKILL kills it
sleep 60 & dead=$!
kill -9 "$dead"; wait "$dead" 2>/dev/null
checks=$((checks + 1))
kill -0 "$dead" 2>/dev/null && fail "PID $dead still running"
live=$$

# plant DIR: the temporaries a killed run leaves, and what must stay
plant() {
  mkdir -p "$1"
  echo a >"$1/.envl-$dead-0-specular_00.exr"          # prefilter's, its process gone
  echo b >"$1/.envl-$dead-1-prefilter.json-old"        # its backup of an old file
  echo c >"$1/.envl-$dead-x.exr.tmp-Ab12Cd"            # a single file's
  echo d >"$1/.envl-$live-0-old.exr"                   # a running process's, two days old:
  touch -d '2 days ago' "$1/.envl-$live-0-old.exr"     #   its PID reused since
  echo e >"$1/.envl-$live-0-irradiance.exr"            # a running process's, recent: kept
  echo f >"$1/.envl-abc-0-x.exr"                       # not a PID: kept
  echo g >"$1/.envl-${dead}x-0-x.exr"                  # not a PID: kept
  echo h >"$1/keep.exr"                                # the user's: kept
  echo i >"$1/target"
  ln -s target "$1/.envl-$dead-0-link.exr"             # a symbolic link: kept
  if [ "$(id -u)" = 0 ]; then
    echo j >"$1/.envl-$dead-0-nobody.exr"              # another user's: kept
    chown nobody "$1/.envl-$dead-0-nobody.exr"
  fi
}
# left DIR: the planted files that must be gone are, the others stay
left() {
  local d=$1 f
  for f in ".envl-$dead-0-specular_00.exr" ".envl-$dead-1-prefilter.json-old" \
           ".envl-$dead-x.exr.tmp-Ab12Cd" ".envl-$live-0-old.exr"; do
    checks=$((checks + 1))
    [ ! -e "$d/$f" ] || fail "$d/$f: a stale temporary not removed"
  done
  for f in ".envl-$live-0-irradiance.exr" ".envl-abc-0-x.exr" ".envl-${dead}x-0-x.exr" \
           keep.exr target ".envl-$dead-0-link.exr"; do
    checks=$((checks + 1))
    [ -e "$d/$f" ] || [ -L "$d/$f" ] || fail "$d/$f: removed, but not a stale temporary"
  done
  if [ "$(id -u)" = 0 ]; then
    checks=$((checks + 1))
    [ -e "$d/.envl-$dead-0-nobody.exr" ] || fail "$d: another user's temporary removed"
  fi
}

S=(--sky-width 32 --quiet)
plant pre
run "$ENVLIGHT" prefilter - -o pre --size 16 --levels 2 --samples 8 "${S[@]}"
left pre
plant one
run "$ENVLIGHT" convert - one/x.exr "${S[@]}"
left one
plant json
run "$ENVLIGHT" lights - --json -o json/l.json "${S[@]}"
left json
# a folder only read from is left as it is
plant read
cp one/x.exr read/in.exr
run "$ENVLIGHT" info read/in.exr
checks=$((checks + 1))
[ -e "read/.envl-$dead-0-specular_00.exr" ] || fail "read/: cleaned by a run that wrote nothing there"
finish
