#!/usr/bin/env bash
# Progress on stderr: on a terminal (util-linux `script` gives the commands one) convert and
# bench print the progress line with their stages' names; with stderr a file, nothing extra.
source "$(dirname "$0")/clitest.sh"
command -v script >/dev/null || { echo "SKIP: util-linux script not installed"; exit 77; }

# on_tty COMMAND: runs COMMAND (one shell string) on a terminal; what it showed in tty.txt,
# one line per carriage return
on_tty() { checks=$((checks + 1))
  script -qec "$1" /dev/null >tty.raw 2>&1 || { fail "exit $?: $1"; cat tty.raw; }
  tr '\r' '\n' <tty.raw >tty.txt; }

run "$ENVLIGHT" convert - in.exr --sky-width 64
empty err.txt
# convert: reading, the canonical frame, the resampling to the layout asked, the writing
on_tty "'$ENVLIGHT' convert in.exr cross.hdr --layout-out cross --size 16"
for stage in 'reading the file' 'to the canonical lat-long frame' 'resampling to cross' \
             'writing cross.hdr'; do
  has tty.txt "^envlight: $stage  *[0-9]* %"
done
on_tty "'$ENVLIGHT' convert in.exr same.pfm"
has tty.txt '^envlight: writing same.pfm  *0 %'
# --quiet: nothing on the terminal either
on_tty "'$ENVLIGHT' convert in.exr quiet.pfm --quiet"
hasnt tty.txt 'envlight:'
# stderr a file: nothing
run "$ENVLIGHT" convert in.exr cross2.hdr --layout-out cross --size 16
empty err.txt
cmp -s cross.hdr cross2.hdr || { checks=$((checks + 1)); fail "cross.hdr differs on a terminal"; }

# bench: a line per case, named, the tables (stdout a file) as without the display
bench=(bench - --sky-width 64 --quick --runs 1 --only tables)
on_tty "'$ENVLIGHT' ${bench[*]} >tables.md"
for stage in 'loading built-in sky' 'lights median 4: built-in sky' 'SH hann order 2: built-in sky' \
             'GGX 0.50, M = 64: built-in sky' 'irradiance map exact: built-in sky'; do
  has tty.txt "^envlight: $stage  *[0-9]* %"
done
has tables.md '#### Lights: built-in sky'
run "$ENVLIGHT" "${bench[@]}"
empty err.txt
# stdout on the same terminal: the tables' cells are the progress, no line among them
on_tty "'$ENVLIGHT' ${bench[*]}"
hasnt tty.txt 'envlight:'
has tty.txt '#### Lights: built-in sky'
finish
