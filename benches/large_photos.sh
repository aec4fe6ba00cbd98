#!/usr/bin/env bash
# Camera-size photographs: caoen beside cwebp and avifenc in one run, on one core each.
#
#   benches/large_photos.sh [PHOTO.jpg] [WORKDIR]
#
# Makes the 0.75 MP and 48 MP versions of the photo (ImageMagick: a quarter and twice
# the size per side), then times every encoder and decoder as a
# whole process with /usr/bin/time (CPU seconds, wall seconds, peak RSS) and prints a
# Markdown table (docs/benchmarks.md, "Large photographs"). caoen runs with -j 1 and
# -j 2; the peers run single-threaded, as their defaults are. Every tool runs ROUNDS
# times (default 3), the tools taking turns, and the table holds each one's median
# times and largest RSS; the ratios below it are the medians of the rounds' ratios,
# each between runs a few seconds apart, so that a shared machine's drift cancels.
set -euo pipefail
cd "$(dirname "$0")/.."
photo=${1:-../shared/large/012mp-bus.jpg}
work=${2:-$(mktemp -d)}
mkdir -p "$work"
caoen=${CAOEN:-target/release/caoen}
for tool in "$caoen" cwebp dwebp avifenc avifdec convert /usr/bin/time; do
  command -v "$tool" >/dev/null || { echo "missing: $tool" >&2; exit 1; }
done

convert "$photo" -resize 25% -quality 95 "$work/0.75mp.png"
convert "$photo" "$work/12mp.png"
convert "$photo" -filter Lanczos -resize 200% "$work/48mp.png"

rounds=${ROUNDS:-3}
log=$work/times.txt
: >"$log"

# run SIZE NAME OUT CMD...: appends "SIZE NAME round cpu wall rss_kb out" to the log.
run() {
  local size=$1 name=$2 out=$3
  shift 3
  /usr/bin/time -f "%U %S %e %M" -o "$work/time.txt" "$@" >/dev/null 2>&1
  awk -v s="$size" -v n="$name" -v r="$round" -v o="$out" \
    '{printf "%s %s %s %.2f %.2f %d %s\n", s, n, r, $1 + $2, $3, $4, o}' "$work/time.txt" >>"$log"
}

sizes="0.75mp 12mp 48mp"
for round in $(seq 1 "$rounds"); do
  echo "round $round of $rounds" >&2
  for size in $sizes; do
    src=$work/$size.png
    run "$size" caoen-encode-j1 "$work/$size.cae" "$caoen" encode "$src" -o "$work/$size.cae" -f --quiet -j 1
    run "$size" caoen-encode-j2 "$work/$size-j2.cae" "$caoen" encode "$src" -o "$work/$size-j2.cae" -f --quiet -j 2
    cmp "$work/$size.cae" "$work/$size-j2.cae"
    run "$size" cwebp-m6-q75 "$work/$size.webp" cwebp -quiet -m 6 -q 75 "$src" -o "$work/$size.webp"
    run "$size" avifenc-s6 "$work/$size.avif" avifenc -s 6 -j 1 "$src" "$work/$size.avif"
    run "$size" caoen-decode-j1 "$work/$size-cae.png" "$caoen" decode "$work/$size.cae" -o "$work/$size-cae.png" -f --quiet -j 1
    run "$size" dwebp "$work/$size-webp.png" dwebp "$work/$size.webp" -o "$work/$size-webp.png"
    # dav1d (avifdec's default) refuses the 48 MP frame; aom decodes it.
    run "$size" avifdec-aom "$work/$size-avif.png" avifdec -c aom -j 1 "$work/$size.avif" "$work/$size-avif.png"
  done
done

echo "| image | pixels | tool | CPU s | wall s | peak RSS MB | bytes/pixel | file bytes |"
echo "|---|---|---|---|---|---|---|---|"
for size in $sizes; do
  read -r w h < <(identify -format "%w %h\n" "$work/$size.png")
  python3 - "$log" "$size" "$w" "$h" <<'PY'
import os, statistics, sys
log, size, w, h = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
rows = [l.split() for l in open(log) if l.split()[0] == size]
tools = list(dict.fromkeys(r[1] for r in rows))
for t in tools:
    mine = [r for r in rows if r[1] == t]
    cpu = statistics.median(float(r[3]) for r in mine)
    wall = statistics.median(float(r[4]) for r in mine)
    rss = max(int(r[5]) for r in mine)
    print(f"| {size} | {w}x{h} | {t} | {cpu:.2f} | {wall:.2f} | {rss / 1024:.0f} | {rss * 1024 / (w * h):.1f} | {os.path.getsize(mine[0][6])} |")
PY
done
echo
python3 - "$log" <<'PY'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1])]
cpu = {(r[0], r[1], r[2]): float(r[3]) for r in rows}
for size in dict.fromkeys(r[0] for r in rows):
    for a, b in [("caoen-encode-j1", "cwebp-m6-q75"), ("caoen-decode-j1", "dwebp")]:
        ratios = sorted(cpu[(size, a, r)] / max(cpu[(size, b, r)], 0.01) for (s, t, r) in cpu if s == size and t == a)
        print(f"- {size}: {a} / {b} CPU: median {statistics.median(ratios):.2f}x (rounds: {', '.join(f'{x:.2f}' for x in ratios)})")
PY
