#!/usr/bin/env bash
# Camera-size photographs: caoen beside cwebp and avifenc in one run, on one core each.
#
#   benches/large_photos.sh [PHOTO.jpg] [WORKDIR]
#
# Makes the 0.75 MP and 48 MP versions of the photo (ImageMagick: a quarter and twice
# the size per side), then times every encoder and decoder as a
# whole process with /usr/bin/time (CPU seconds, wall seconds, peak RSS) and prints a
# Markdown table (docs/benchmarks.md, "Large photographs"). caoen runs with -j 1 and
# -j 2; the peers run single-threaded, as their defaults are.
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

# run NAME CMD...: one line "NAME cpu wall rss_kb" on stdout.
run() {
  local name=$1
  shift
  /usr/bin/time -f "$name %U %S %e %M" -o "$work/time.txt" "$@" >/dev/null 2>&1
  awk '{printf "%s %.2f %.2f %d\n", $1, $2 + $3, $4, $5}' "$work/time.txt"
}

echo "| image | pixels | tool | CPU s | wall s | peak RSS MB | bytes/pixel | file bytes |"
echo "|---|---|---|---|---|---|---|---|"
for size in 0.75mp 12mp 48mp; do
  src=$work/$size.png
  read -r w h < <(identify -format "%w %h\n" "$src")
  px=$((w * h))
  dims=${w}x$h
  line() { # name file
    read -r name cpu wall rss
    printf "| %s | %s | %s | %s | %s | %.0f | %.1f | %s |\n" "$size" "$dims" "$name" "$cpu" "$wall" \
      "$(echo "$rss / 1024" | bc -l)" "$(echo "$rss * 1024 / $px" | bc -l)" "$(stat -c %s "$2" 2>/dev/null || echo -)"
  }
  run "caoen-encode-j1" "$caoen" encode "$src" -o "$work/$size.cae" -f --quiet -j 1 | line _ "$work/$size.cae"
  run "caoen-encode-j2" "$caoen" encode "$src" -o "$work/$size-j2.cae" -f --quiet -j 2 | line _ "$work/$size-j2.cae"
  cmp "$work/$size.cae" "$work/$size-j2.cae"
  run "cwebp-m6-q75" cwebp -quiet -m 6 -q 75 "$src" -o "$work/$size.webp" | line _ "$work/$size.webp"
  run "avifenc-s6" avifenc -s 6 -j 1 "$src" "$work/$size.avif" | line _ "$work/$size.avif"
  run "caoen-decode-j1" "$caoen" decode "$work/$size.cae" -o "$work/$size-cae.png" -f --quiet -j 1 | line _ "$work/$size-cae.png"
  run "dwebp" dwebp "$work/$size.webp" -o "$work/$size-webp.png" | line _ "$work/$size-webp.png"
  # dav1d (avifdec's default) refuses the 48 MP frame; aom decodes it.
  run "avifdec-aom" avifdec -c aom -j 1 "$work/$size.avif" "$work/$size-avif.png" | line _ "$work/$size-avif.png"
done
