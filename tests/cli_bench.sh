#!/usr/bin/env bash
# envlight bench: the tables on a small built-in sky, the CSV of every point and the plots.
# Asserted is what must hold whatever the machine's speed: every error is finite and >= 0,
# every point has a positive time, and the exact irradiance map is closer than SH of order 1
# (which keeps only the mean and the linear term of a sky with a sun).
source "$(dirname "$0")/clitest.sh"

run "$ENVLIGHT" bench - --sky-width 128 --quick --runs 1 --only tables --csv points.csv --plots plots
has out.txt '#### Lights: built-in sky'
has out.txt '#### SH irradiance: built-in sky'
has out.txt '#### Specular (GGX, prefiltered levels): built-in sky'
has out.txt '#### Irradiance map (64 x 32): built-in sky'
has points.csv '^map,measure,series,param,count,error,seconds$'
for series in median variance fit sh-none sh-auto ggx-r0.50-samples ggx-r0.50-size \
              irradiance-sh irradiance-resampled irradiance-exact; do
  has points.csv "^built-in sky,[a-z]*,$series,"
done
checks=$((checks + 1))
awk -F, 'NR > 1 && !($6 >= 0 && $6 < 1e6 && $7 > 0) { print "bad point: " $0; bad = 1 }
         END { exit bad }' points.csv || fail "points.csv has a non-finite error or time"
checks=$((checks + 1))
awk -F, '$3 == "irradiance-sh" && $4 == 1 { sh1 = $6 } $3 == "irradiance-exact" { ex = $6 }
         END { exit !(ex < sh1) }' points.csv || fail "exact irradiance map not closer than SH order 1"
for kind in diffuse glossy; do
  checks=$((checks + 1))
  head -c 8 "plots/built-in_sky-$kind.png" | od -An -tx1 | grep -q '89 50 4e 47' ||
    fail "plots/built-in_sky-$kind.png is not a PNG"
done
usage "$ENVLIGHT" bench --runs 0
usage "$ENVLIGHT" bench --only nothing
finish
