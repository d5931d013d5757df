#!/usr/bin/env bash
# Regenerate docs/animate/arm.png: a 2 s `posfb animate` page rendered by
# headless Chromium (software WebGL, no GPU, no network).
#
#   docs/animate/screenshot.sh [OUT.png]
#
# Needs Chromium (Debian: apt-get install chromium); CHROMIUM=... picks another
# binary. The page is loaded from a file:// URL; it opens no connection.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="$(realpath -m "${1:-$here/arm.png}")"
posfb="$root/.venv/bin/posfb"
[[ -x "$posfb" ]] || posfb="posfb"
chromium="${CHROMIUM:-$(command -v chromium || command -v chromium-browser || true)}"
if [[ -z "$chromium" ]]; then
    echo "screenshot.sh: no chromium found (apt-get install chromium, or set CHROMIUM)" >&2
    exit 1
fi

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

"$posfb" animate --out "$work/arm.html" --duration 2
# The recording autoplays in a loop; 3 s of virtual time shows it about 1 s in.
"$chromium" --headless --no-sandbox --disable-gpu --use-gl=swiftshader \
    --enable-unsafe-swiftshader --hide-scrollbars --user-data-dir="$work/profile" \
    --disable-background-networking --disable-component-update --disable-sync --no-first-run \
    --window-size=1024,768 --virtual-time-budget=3000 \
    --screenshot="$out" "file://$work/arm.html" 2>"$work/chromium.log" \
    || { cat "$work/chromium.log" >&2; exit 1; }
[[ -s "$out" ]] || { cat "$work/chromium.log" >&2; echo "no screenshot written" >&2; exit 1; }
echo "$out"
