#!/bin/sh
# Builds the WebAssembly decoder into tools/web/pkg/: caoen.js (an ES module exporting
# initSync, info, decode, decodeRegion and the default async init) beside caoen_bg.wasm.
#
# Needs the wasm32-unknown-unknown target and wasm-bindgen-cli of exactly the version of
# the wasm-bindgen crate in Cargo.lock (the two must match):
#   rustup target add wasm32-unknown-unknown
#   cargo install wasm-bindgen-cli --version "$(tools/web/build.sh --bindgen-version)"
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
want=$(awk '/^name = "wasm-bindgen"$/ { getline; gsub(/"/, "", $3); print $3; exit }' "$root/Cargo.lock")
if [ "${1:-}" = "--bindgen-version" ]; then
    echo "$want"
    exit 0
fi
have=$(wasm-bindgen --version 2>/dev/null | awk '{ print $2 }') || true
if [ "$have" != "$want" ]; then
    echo "build.sh: wasm-bindgen $want is needed (found: ${have:-none}):" >&2
    echo "  cargo install wasm-bindgen-cli --version $want" >&2
    exit 1
fi
target=${CARGO_TARGET_DIR:-$root/target}
cargo build --manifest-path "$root/Cargo.toml" -p caoen-web \
    --target wasm32-unknown-unknown --profile wasm
rm -rf "$here/pkg"
wasm-bindgen --target web --no-typescript --out-dir "$here/pkg" --out-name caoen \
    "$target/wasm32-unknown-unknown/wasm/caoen_web.wasm"
wasm=$here/pkg/caoen_bg.wasm
echo "build.sh: $wasm: $(wc -c < "$wasm") bytes, $(gzip -9 -c "$wasm" | wc -c) gzipped"
