#!/usr/bin/env bash
# Every kind of output on a full disk (issue 19): a small tmpfs holds a good copy of each output,
# is then filled, and each command writing there again must exit 1 within 60 s (an OpenEXR
# header write once deadlocked on ENOSPC), name the file and the cause, leave the old output
# byte-identical and no temporary file (.envl-*); a prefilter into a folder it creates leaves
# no folder (issue 30). Needs root (mount); skipped otherwise.
. "$(dirname "$0")/clitest.sh"

full=$PWD/full
mkdir -p "$full"
mountpoint -q "$full" && umount "$full"
if [ "$(id -u)" != 0 ]; then
  echo "SKIP: mounting a tmpfs needs root"; exit 77
fi
if ! mount -t tmpfs -o size=1m,mode=0755 tmpfs "$full" 2>mount.txt; then
  echo "SKIP: cannot mount a tmpfs on $full: $(cat mount.txt)"; exit 77
fi
trap 'umount "$full" 2>/dev/null' EXIT

sky=(--sky-width 16 --quiet)
pre=(--size 16 --levels 2 --samples 16)
# The outputs as they are before the disk fills (each command also runs below, on the full disk).
expect 0 "exr" -- "$ENVLIGHT" convert - "$full/o.exr" "${sky[@]}"
expect 0 "half exr" -- "$ENVLIGHT" convert - "$full/h.exr" --half "${sky[@]}"
expect 0 "hdr" -- "$ENVLIGHT" convert - "$full/o.hdr" "${sky[@]}"
expect 0 "pfm" -- "$ENVLIGHT" convert - "$full/o.pfm" "${sky[@]}"
expect 0 "preview png" -- "$ENVLIGHT" preview - -o "$full/p.png" "${sky[@]}"
expect 0 "brdf-lut png + json" -- "$ENVLIGHT" brdf-lut -o "$full/b.png" --size 16 --samples 16
expect 0 "prefilter exr" -- "$ENVLIGHT" prefilter - -o "$full/pre" "${pre[@]}" "${sky[@]}"
expect 0 "prefilter rgbm-png" -- "$ENVLIGHT" prefilter - -o "$full/prepng" --format rgbm-png \
  "${pre[@]}" "${sky[@]}"
expect 0 "prefilter ktx2" -- "$ENVLIGHT" prefilter - -o "$full/prektx" --format ktx2 \
  "${pre[@]}" "${sky[@]}"
expect 0 "lights --residual" -- "$ENVLIGHT" lights - --residual "$full/res.exr" "${sky[@]}"
expect 0 "lights json" -- "$ENVLIGHT" lights - --json -o "$full/l.json" "${sky[@]}"
expect 0 "sh json" -- "$ENVLIGHT" sh - --json -o "$full/sh.json" "${sky[@]}"
expect 0 "pov include" -- "$ENVLIGHT" pov - -o "$full/a.inc" "${sky[@]}"
rm -rf keep && cp -a "$full" keep

dd if=/dev/zero of="$full/fill" bs=4k 2>/dev/null
checks=$((checks + 1))
: > "$full/probe" && ! dd if=/dev/zero of="$full/probe" bs=4k count=1 2>/dev/null ||
  fail "the tmpfs is not full"
rm -f "$full/probe"

# on_full WHAT NAMED -- COMMAND...: COMMAND (the rotation makes new content) must fail as said.
on_full() {
  local what=$1 named=$2; shift 3
  checks=$((checks + 1))
  timeout 60 "$@" >out.txt 2>err.txt
  local rc=$?
  if [ $rc = 124 ]; then
    fail "$what: hung (killed after 60 s): $*"
  elif [ $rc != 1 ]; then
    fail "$what: exit $rc, expected 1: $*"; cat err.txt
  fi
  has err.txt "$named"
  has err.txt "No space left on device"
  checks=$((checks + 1))
  local left
  left=$(find "$full" -name '*.tmp-*' -o -name '.envl-*')
  [ -z "$left" ] || { fail "$what: temporary files left behind: $left"; rm -f $left; }
  checks=$((checks + 1))
  diff -r --exclude=fill keep "$full" >diff.txt ||
    { fail "$what: the old outputs changed:"; cat diff.txt; }
}
r=(--rotate 90 "${sky[@]}")
on_full "exr" "$full/o.exr" -- "$ENVLIGHT" convert - "$full/o.exr" "${r[@]}"
on_full "half exr" "$full/h.exr" -- "$ENVLIGHT" convert - "$full/h.exr" --half "${r[@]}"
on_full "hdr" "$full/o.hdr" -- "$ENVLIGHT" convert - "$full/o.hdr" "${r[@]}"
on_full "pfm" "$full/o.pfm" -- "$ENVLIGHT" convert - "$full/o.pfm" "${r[@]}"
on_full "preview png" "$full/p.png" -- "$ENVLIGHT" preview - -o "$full/p.png" "${r[@]}"
on_full "brdf-lut png" "$full/b.png" -- "$ENVLIGHT" brdf-lut -o "$full/b.png" --size 16 \
  --samples 32
on_full "prefilter exr" "$full/pre/" -- "$ENVLIGHT" prefilter - -o "$full/pre" "${pre[@]}" \
  "${r[@]}"
on_full "prefilter rgbm-png" "$full/prepng/" -- "$ENVLIGHT" prefilter - -o "$full/prepng" \
  --format rgbm-png "${pre[@]}" "${r[@]}"
on_full "prefilter ktx2" "$full/prektx/" -- "$ENVLIGHT" prefilter - -o "$full/prektx" \
  --format ktx2 "${pre[@]}" "${r[@]}"
# a folder the run created goes again when the run fails (issue 30, 4.11)
on_full "prefilter into a new folder" "$full/new/" -- "$ENVLIGHT" prefilter - -o "$full/new" \
  "${pre[@]}" "${r[@]}"
on_full "lights --residual" "$full/res.exr" -- "$ENVLIGHT" lights - --residual "$full/res.exr" \
  "${r[@]}"
on_full "lights json" "$full/l.json" -- "$ENVLIGHT" lights - --json -o "$full/l.json" "${r[@]}"
on_full "sh json" "$full/sh.json" -- "$ENVLIGHT" sh - --json -o "$full/sh.json" "${r[@]}"
on_full "pov include" "$full/a.inc" -- "$ENVLIGHT" pov - -o "$full/a.inc" "${r[@]}"

finish
