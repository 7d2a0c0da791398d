#!/usr/bin/env bash
# The libraries the report page inlines, taken from what `npm ci` installs
# from package-lock.json and committed under vendor/, so that `cargo build`
# needs neither node nor the network.
#
#   view/web/vendor.sh          npm ci, then copy the files into vendor/
#   view/web/vendor.sh --check  npm ci, then fail if vendor/ differs
set -euo pipefail
cd "$(dirname "$0")"
npm ci --ignore-scripts --no-audit --no-fund --loglevel=error >/dev/null
files=(
  "@dagrejs/dagre/dist/dagre.min.js"
  "@dagrejs/dagre/dist/dagre.min.js.LEGAL.txt"
)
status=0
for f in "${files[@]}"; do
  src="node_modules/$f"
  dst="vendor/$(basename "$f")"
  if [ "${1:-}" = "--check" ]; then
    if ! cmp -s "$src" "$dst"; then
      echo "view/web/$dst differs from $f of package-lock.json: run view/web/vendor.sh" >&2
      status=1
    fi
  else
    mkdir -p vendor
    cp "$src" "$dst"
  fi
done
exit "$status"
