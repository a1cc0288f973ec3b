#!/usr/bin/env bash
# Blender 4.x (Debian 13 trixie's package) on this Debian 12 machine, for trying the add-on
# and its tests against Blender 4 (issue 14):
#
#     sudo bash scripts/blender4.sh            # last line of stdout: the command to run
#     B4=$(sudo bash scripts/blender4.sh | tail -1)
#     $B4 --version
#     $B4 -b --factory-startup --python scripts/blender_addon_check.py -- /tmp/spec.json
#
# Once, under ${ENVL_CACHE:-/var/cache/envlight}/trixie-root, it makes a minimal trixie root
# (debootstrap --variant=minbase; the host's debootstrap package is installed when missing),
# installs blender, xvfb, xauth and python3-numpy in it, and writes ROOT/run-blender: that
# wrapper runs `blender "$@"` chrooted into ROOT inside its own mount namespace
# (unshare --mount), where /proc, /sys, /dev, /tmp, the repository's parent folder (so the
# repository and ../shared) and the folders in $ENVL_BLENDER4_BINDS (colon-separated) are
# bound at the same paths: absolute paths under them work as arguments, nothing stays mounted
# after it exits, concurrent calls are independent, the environment passes through (PATH is
# set to the root's own), the current folder is kept when it exists inside, and its exit
# status is Blender's.
#
# Idempotent: the root is ready when ROOT/.envlight-ready (written at the very end) holds this
# script's package list; a second run then only (re)writes the wrapper and takes well under a
# second. A root whose debootstrap did not finish (no ROOT/.envlight-debootstrap-done) is
# removed and made again; one whose package step did not finish gets that step again.
# Everything but the last line goes to stderr, with the time each step took.
#
# Needs root (debootstrap, unshare --mount, chroot). Environment:
#   ENVL_CACHE            cache folder (default /var/cache/envlight)
#   ENVL_DEBIAN_MIRROR    Debian mirror (default: the host's from /etc/apt/sources.list*)
#   ENVL_BLENDER4_BINDS   (wrapper, at run time) more host folders to bind, colon-separated
#   ENVL_BLENDER4_XVFB=1  (wrapper, at run time) run Blender under the root's own xvfb-run -a
#                         (for a window without the host's xvfb; the host's xvfb-run around
#                         the wrapper works too: /tmp/.X11-unix and its Xauthority are shared)
case "${1:-}" in  # --help: the usage and the header above, nothing run
  -h|--help) echo "usage: bash scripts/blender4.sh   (as root; last line of stdout: the command that runs Blender 4)"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
esac
set -euo pipefail

exec 3>&1 1>&2 # stdout is for the last line only (fd 3)

SUITE=trixie
# libegl1 + libegl-mesa0: EEVEE-Next renders in `blender -b` through EGL on Mesa's software
# rasteriser (llvmpipe, OpenGL 4.5; no X server needed); without them it aborts with "Couldn't
# open libEGL.so.1"
PACKAGES="blender xvfb xauth python3-numpy libegl1 libegl-mesa0"
CONFIG="suite=$SUITE packages=$PACKAGES"
CACHE=${ENVL_CACHE:-/var/cache/envlight}
ROOT=$CACHE/$SUITE-root
WRAPPER=$ROOT/run-blender
READY=$ROOT/.envlight-ready
BOOTSTRAPPED=$ROOT/.envlight-debootstrap-done
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
REPO_PARENT=$(dirname "$REPO")
# what the wrapper binds besides /tmp: the repository's parent (the repository and ../shared);
# when that is / (which cannot be bound), the repository and its sibling shared/
if [ "$REPO_PARENT" = / ]; then REPO_BINDS=$REPO:/shared; else REPO_BINDS=$REPO_PARENT; fi

T_START=$(date +%s.%N)
T_STEP=$T_START
log() { echo "blender4.sh: $*"; }
die() { echo "blender4.sh: error: $*"; exit 1; }
step_done() { # step_done NAME: prints the time since the previous step
    local now
    now=$(date +%s.%N)
    awk -v n="$1" -v a="$now" -v b="$T_STEP" 'BEGIN { printf "blender4.sh: [time] %-34s %7.1f s\n", n, a - b }'
    T_STEP=$now
}

[ "$(id -u)" = 0 ] || die "needs root (debootstrap, unshare --mount, chroot): run it with sudo"
for tool in unshare chroot flock mount findmnt; do
    command -v "$tool" >/dev/null || die "$tool not found (util-linux / coreutils)"
done

mkdir -p "$CACHE"
exec 9>"$CACHE/$SUITE-root.lock"
if ! flock -n 9; then
    log "another blender4.sh is working on $ROOT: waiting for it"
    flock 9
fi
step_done "lock"

# The host's Debian mirror (the first deb source that is not a security one).
host_mirror() {
    local f u
    for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list /etc/apt/sources.list.d/*.sources; do
        [ -f "$f" ] || continue
        u=$(awk '/^[[:space:]]*URIs:/ { for (i = 2; i <= NF; i++) print $i }
                 /^[[:space:]]*deb[[:space:]]/ { for (i = 2; i <= NF; i++) if ($i ~ /:\/\//) { print $i; break } }' "$f" |
            grep -E '/debian/?$' | grep -v -- '-security' | head -1 || true)
        if [ -n "$u" ]; then echo "${u%/}"; return; fi
    done
    echo http://deb.debian.org/debian
}

# run_in_root CMD...: CMD chrooted into ROOT in a private mount namespace with /proc, /sys and
# /dev bound (the mounts end with the namespace, also when interrupted).
run_in_root() {
    unshare --mount --propagation private --fork --kill-child -- /bin/bash -c '
        set -e
        root=$1; shift
        for d in /proc /sys /dev; do mount --rbind "$d" "$root$d"; done
        exec chroot "$root" /usr/bin/env -i PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
            HOME=/root LANG=C.UTF-8 DEBIAN_FRONTEND=noninteractive "$@"' run_in_root "$ROOT" "$@"
}

# Refuses to go on when something is mounted under ROOT in this namespace (rm -rf would go
# through it): debootstrap and the wrapper mount only inside their own namespaces.
check_no_mounts() {
    local m
    m=$(findmnt -rn -o TARGET | awk -v r="$ROOT" 'index($0, r "/") == 1 || $0 == r' || true)
    [ -z "$m" ] || die "mounted under $ROOT (unmount first): $m"
}

write_wrapper() {
    local tmp=$WRAPPER.tmp.$$
    cat >"$tmp" <<'EOF'
#!/bin/bash
# Written by envlight's scripts/blender4.sh: runs Debian @SUITE@'s Blender chrooted into
# @ROOT@ in a private mount namespace where /proc, /sys, /dev, /tmp, @REPO_BINDS@ and the
# folders in $ENVL_BLENDER4_BINDS (colon-separated) are bound at their own paths.
# Usage: run-blender [blender arguments...]; exit status: Blender's. Needs root.
set -euo pipefail
ROOT=@ROOT@
BINDS=/tmp:@REPO_BINDS@
if [ -z "${_ENVL_BLENDER4_NS:-}" ]; then
    [ "$(id -u)" = 0 ] || { echo "run-blender: needs root (unshare --mount, chroot)" >&2; exit 125; }
    _ENVL_BLENDER4_NS=1 exec unshare --mount --propagation private --fork --kill-child -- \
        /bin/bash "$(readlink -f "${BASH_SOURCE[0]}")" "$@"
fi
unset _ENVL_BLENDER4_NS
for d in /proc /sys /dev; do mount --rbind "$d" "$ROOT$d"; done
IFS=: read -r -a binds <<<"$BINDS:${ENVL_BLENDER4_BINDS:-}"
done_binds=:
for b in "${binds[@]}"; do
    [ -n "$b" ] && [ -d "$b" ] || continue
    b=$(readlink -f "$b")
    [ "$b" != / ] || { echo "run-blender: cannot bind / (skipped)" >&2; continue; }
    case $done_binds in *":$b:"*) continue ;; esac
    mkdir -p "$ROOT$b"
    mount --rbind "$b" "$ROOT$b"
    done_binds=$done_binds$b:
done
[ -d "$ROOT${HOME:-/nonexistent}" ] || export HOME=/root
export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
# ENVL_BLENDER4_XVFB=1: Blender with a window on the root's own Xvfb (xvfb-run -a inside)
xvfb=
[ "${ENVL_BLENDER4_XVFB:-0}" = 0 ] || xvfb=1
unset ENVL_BLENDER4_XVFB
exec chroot "$ROOT" /bin/sh -c 'cd "$1" 2>/dev/null || cd /
    if [ -n "$2" ]; then shift 2; exec xvfb-run -a -s "-screen 0 1280x800x24" blender "$@"; fi
    shift 2; exec blender "$@"' run-blender "$PWD" "$xvfb" "$@"
EOF
    sed -i -e "s|@ROOT@|$ROOT|g" -e "s|@SUITE@|$SUITE|g" -e "s|@REPO_BINDS@|$REPO_BINDS|g" "$tmp"
    chmod 755 "$tmp"
    if [ -f "$WRAPPER" ] && cmp -s "$tmp" "$WRAPPER"; then
        rm -f "$tmp"
    else
        mv -f "$tmp" "$WRAPPER"
        log "wrote $WRAPPER"
    fi
}

# small fixes to the root, also on a ready one: Blender lists mounts through /etc/mtab
# ("could not get a list of mounted file-systems" without it)
tweak_root() {
    [ -e "$ROOT/etc/mtab" ] || [ -L "$ROOT/etc/mtab" ] || ln -s ../proc/self/mounts "$ROOT/etc/mtab"
}

if [ -f "$READY" ] && [ "$(cat "$READY")" = "$CONFIG" ] && [ -x "$ROOT/usr/bin/blender" ]; then
    log "$ROOT is ready ($(cat "$ROOT/etc/debian_version" 2>/dev/null || echo '?'))"
    tweak_root
    write_wrapper
    step_done "check (root ready)"
else
    MIRROR=${ENVL_DEBIAN_MIRROR:-$(host_mirror)}
    log "making $ROOT (Debian $SUITE from $MIRROR)"
    rm -f "$READY"
    if [ ! -f "$BOOTSTRAPPED" ]; then
        if ! command -v debootstrap >/dev/null; then
            log "installing debootstrap on the host"
            apt-get update -qq
            DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends debootstrap
            step_done "apt-get install debootstrap"
        fi
        script=
        if [ ! -e "/usr/share/debootstrap/scripts/$SUITE" ]; then
            script=/usr/share/debootstrap/scripts/sid # an older debootstrap: trixie is sid's
        fi
        if [ -e "$ROOT" ]; then
            log "$ROOT: an unfinished debootstrap: removing it"
            check_no_mounts
            rm -rf --one-file-system "$ROOT"
            step_done "remove unfinished root"
        fi
        mkdir -p "$ROOT"
        # in its own mount namespace: the /proc and /sys debootstrap mounts end with it
        unshare --mount --propagation private --fork --kill-child -- \
            debootstrap --variant=minbase --arch=amd64 "$SUITE" "$ROOT" "$MIRROR" $script
        touch "$BOOTSTRAPPED"
        step_done "debootstrap --variant=minbase $SUITE"
    fi
    # no services started by package scripts in the root
    printf '#!/bin/sh\nexit 101\n' >"$ROOT/usr/sbin/policy-rc.d"
    chmod 755 "$ROOT/usr/sbin/policy-rc.d"
    cp -L /etc/resolv.conf "$ROOT/etc/resolv.conf" 2>/dev/null || true
    run_in_root dpkg --configure -a
    run_in_root apt-get update -qq
    step_done "apt-get update (root)"
    # shellcheck disable=SC2086
    run_in_root apt-get install -y -q --no-install-recommends $PACKAGES
    run_in_root apt-get clean
    step_done "apt-get install $PACKAGES"
    tweak_root
    write_wrapper
    version=$("$WRAPPER" --version 2>&1 | grep -m1 '^Blender ' || true)
    case $version in
        "Blender 4."*) log "$version" ;;
        *) die "$WRAPPER --version did not print Blender 4.x: '$version'" ;;
    esac
    step_done "blender --version"
    echo "$CONFIG" >"$READY" # the very end: the root is complete
fi
T_STEP=$T_START
step_done "total"
echo "$WRAPPER" >&3
